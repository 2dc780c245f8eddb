#!/usr/bin/env bash
# A scene-gen dataset on a Slurm cluster: one array task per shard, then one merge job.
# Submit with:   bash docs/jobs/dataset_slurm.sh
# DIR must be on a file system every node sees. Edit the settings below.
set -euo pipefail

SHARDS=16
DIR=/shared/datasets/imx174-4mm
ARGS="--seeds 0..1000 --camera IMX174,focal_mm=4,pitch_deg=-10 --lighting both --every 4 --out $DIR"

# Array task I runs shard I/SHARDS. A task that is re-queued or resubmitted resumes: it skips
# finished frames. Rendering uses every core Slurm gives the task (rayon).
array=$(sbatch --parsable --array=0-$((SHARDS - 1)) --cpus-per-task=16 --mem=16G --time=04:00:00 \
  --job-name=scene-gen-dataset --output=scene-gen-dataset-%a.log \
  --wrap="scene-gen dataset $ARGS --shard \${SLURM_ARRAY_TASK_ID}/$SHARDS")

# The last shard to finish merges by itself. This job makes sure, and it fails (exit 1)
# and names the missing seeds if a shard failed.
sbatch --dependency=afterok:"$array" --cpus-per-task=1 --mem=4G --time=00:30:00 \
  --job-name=scene-gen-dataset-merge --output=scene-gen-dataset-merge.log \
  --wrap="scene-gen dataset $ARGS --merge"
echo "submitted array $array ($SHARDS shards) and its merge"
