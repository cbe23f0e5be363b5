#!/usr/bin/env bash
# Submits one shot of shatter to Slurm, as examples/farm/shatter.openjd.yaml does on an OpenJD
# farm: a job that runs preprocess, sim and post once (`shatter run --until post`, which skips
# what is up to date and resumes what a killed job left), then a job array that renders the
# frames in chunks once it has succeeded. Renders share the output folder.
#
#   examples/farm/shatter.slurm.sh CONFIG LAST_FRAME [CHUNK_SIZE]
#
# LAST_FRAME is the scene's sim.frames; CHUNK_SIZE frames per array task (default 8). SHATTER
# names the executable (default: shatter on the PATH), SBATCH_OPTIONS extra sbatch options (a
# partition, a time limit), and DRY_RUN=1 prints the sbatch commands instead of running them.
set -euo pipefail

if [ $# -lt 2 ]; then
    echo "usage: $0 CONFIG LAST_FRAME [CHUNK_SIZE]" >&2
    exit 2
fi
config=$(realpath "$1")
last_frame=$2
chunk=${3:-8}
shatter=${SHATTER:-shatter}
read -r -a options <<< "${SBATCH_OPTIONS:-}"
chunks=$(( (last_frame + chunk - 1) / chunk ))

simulate="'$shatter' run --until post --config '$config'"
render="first=\$(( SLURM_ARRAY_TASK_ID * $chunk + 1 )); end=\$(( first + $chunk - 1 )); \
if [ \$end -gt $last_frame ]; then end=$last_frame; fi; \
exec '$shatter' render --frames \$first-\$end --config '$config'"

if [ "${DRY_RUN:-0}" = 1 ]; then
    echo sbatch --parsable --job-name=shatter-simulate "${options[@]}" --wrap="$simulate"
    echo sbatch --dependency=afterok:JOB --array=0-$(( chunks - 1 )) --job-name=shatter-render "${options[@]}" --wrap="$render"
    exit 0
fi
job=$(sbatch --parsable --job-name=shatter-simulate "${options[@]}" --wrap="$simulate")
sbatch --dependency=afterok:"$job" --array=0-$(( chunks - 1 )) --job-name=shatter-render "${options[@]}" --wrap="$render"
