#!/usr/bin/env bash
# ORB keypoints, angles, descriptors and RANSAC inliers against OpenCV (opencv-python-headless).
set -euo pipefail
cd "$(dirname "$0")/../.."
test -x target/release/scene-gen || { echo "check_orb: build target/release/scene-gen first" >&2; exit 1; }
echo "check_orb: scene-gen orb/match vs cv2.ORB_create, BFMatcher(crossCheck), findFundamentalMat(FM_RANSAC)"
.venv/bin/python tests/interop/orb_vs_opencv.py
