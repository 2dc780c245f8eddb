#!/bin/bash
# Mitsuba 3 environment for the renderer comparison (examples/mitsuba/compare.py); not part of
# the test suite. Run from the repository root:  bash examples/mitsuba/setup.sh
#
# Dr.Jit's llvm backend loads libLLVM at run time and needs LLVM >= 15 (opaque pointers);
# Debian 12's default llvm-14 is refused ("the located LLVM version (14) is too old"), so
# libllvm19 is installed from the distribution and DRJIT_LIBLLVM_PATH points at it.
set -euo pipefail
python3 -m venv .venv-mitsuba
.venv-mitsuba/bin/python -m pip install --quiet mitsuba==3.9.1 numpy==2.2.6
LIBLLVM=/usr/lib/x86_64-linux-gnu/libLLVM-19.so
if [ ! -e "$LIBLLVM" ]; then
    if [ "$(id -u)" = 0 ]; then
        apt-get update -qq && apt-get install -y -qq libllvm19
    else
        echo "need $LIBLLVM: run 'apt-get install libllvm19' as root" >&2
        exit 1
    fi
fi
DRJIT_LIBLLVM_PATH=$LIBLLVM .venv-mitsuba/bin/python -c \
    "import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); print('mitsuba', mi.__version__, 'llvm_ad_rgb ok')"
echo "use: export DRJIT_LIBLLVM_PATH=$LIBLLVM"
