#!/usr/bin/env bash
# Submits a sharded capture run and its lookups to Slurm as four dependent jobs:
#   capture array (SHARDS tasks) -> merge (manifest, optionally one joined file)
#   -> lookup array (LOOKUP_SHARDS tasks) -> gather (one CSV)
# Each job starts only when the one before succeeded (afterok); a failed task cancels what
# depends on it. Re-submitting after a failure re-does only the missing or damaged shards.
#
# Usage: submit.sh [options] OUT_DIR SHARDS -- CAPTURE2QT_ARGS...
#   --table T.qt          also shade every capture with this BRDF table (lookup and gather jobs)
#   --lookup-shards L     tasks of the lookup array (default: SHARDS)
#   --wo X,Y,Z            outgoing direction of the lookups (default: the normal)
#   --join                also join the shards into OUT_DIR/captures.qt when it fits one file
#   --partition P         partition of every job
#   --throttle K          at most K array tasks at a time (sbatch --array=...%K)
#   --cpus C              cores per capture task (default 1)
#   --mem-per-cpu M       memory per core of every job, e.g. 2G
#   --time T              time limit of every job (each task of an array), e.g. 1:00:00
#   --merge-cpus C        cores of the merge job, which checks and restores every shard with
#                         all of them (default 1; at 10^8 points it is the serial step)
#   --merge-time T        time limit of the merge job (default --time's)
#   --dry-run             print the sbatch commands instead of running them
# Prints the job IDs, one per line: capture, merge[, lookup, gather]; logs go to OUT_DIR/logs.
# Jobs run in the folder submit.sh runs in, so relative paths in the arguments hold. The tools
# are found in BASIS_BIN (exported to the jobs), else on PATH.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
table="" lookup_shards="" wo="" join="" throttle="" cpus=1 merge_cpus=1 merge_time="" dry_run=0
common=()
while [ $# -gt 0 ]; do
  case $1 in
    --table) table=$(realpath "$2"); shift 2 ;;
    --lookup-shards) lookup_shards=$2; shift 2 ;;
    --wo) wo=$2; shift 2 ;;
    --join) join=--join; shift ;;
    --partition) common+=(--partition="$2"); shift 2 ;;
    --throttle) throttle=%$2; shift 2 ;;
    --cpus) cpus=$2; shift 2 ;;
    --mem-per-cpu) common+=(--mem-per-cpu="$2"); shift 2 ;;
    --time) common+=(--time="$2"); shift 2 ;;
    --merge-cpus) merge_cpus=$2; shift 2 ;;
    --merge-time) merge_time=$2; shift 2 ;;
    --dry-run) dry_run=1; shift ;;
    -h|--help) sed -n '2,24p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) break ;;
  esac
done
if [ $# -lt 3 ] || [ "$3" != -- ]; then
  echo "usage: submit.sh [options] OUT_DIR SHARDS -- CAPTURE2QT_ARGS... (see --help)" >&2
  exit 2
fi
out=$(realpath -m "$1") shards=$2
shift 3
lookup_shards=${lookup_shards:-$shards}
mkdir -p "$out/logs"
common+=(--parsable --kill-on-invalid-dep=yes)
if [ -z "${BASIS_BIN:-}" ]; then
  tool=$(command -v capture2qt || true)
  if [ -z "$tool" ]; then
    echo "submit.sh: capture2qt is not on PATH: set BASIS_BIN to the folder of the tools" >&2
    exit 2
  fi
  BASIS_BIN=$(dirname "$tool")
fi
if [ ! -x "$BASIS_BIN/capture2qt" ]; then
  echo "submit.sh: $BASIS_BIN/capture2qt: no such tool (BASIS_BIN)" >&2
  exit 2
fi
export BASIS_BIN

submit() {  # submit NAME LOG sbatch-arguments...: prints the job ID
  local name=$1 log=$2
  shift 2
  if [ "$dry_run" = 1 ]; then
    echo "sbatch ${common[*]} --output=$out/logs/$log $*" >&2
    echo "$name"
  else
    # --parsable prints "ID" or "ID;CLUSTER": dependencies take the ID.
    sbatch "${common[@]}" --output="$out/logs/$log" "$@" | cut -d';' -f1
  fi
}

capture=$(submit capture "%x-%A_%a.log" --array="0-$((shards - 1))$throttle" --cpus-per-task="$cpus" \
  "$here/capture.sbatch" "$out" "$shards" "$@")
merge_args=(--cpus-per-task="$merge_cpus")
[ -n "$merge_time" ] && merge_args+=(--time="$merge_time")
merge=$(submit merge "%x-%j.log" --dependency=afterok:"$capture" "${merge_args[@]}" \
  "$here/merge.sbatch" "$out" "$shards" $join)
echo "$capture"
echo "$merge"
if [ -n "$table" ]; then
  lookup_args=()
  [ -n "$wo" ] && lookup_args=(--wo "$wo")
  lookup=$(submit lookup "%x-%A_%a.log" --array="0-$((lookup_shards - 1))$throttle" \
    --dependency=afterok:"$merge" "$here/lookup.sbatch" "$out" "$lookup_shards" "$table" \
    ${lookup_args[@]+"${lookup_args[@]}"})
  gather=$(submit gather "%x-%j.log" --dependency=afterok:"$lookup" "$here/gather.sbatch" "$out" \
    "$lookup_shards")
  echo "$lookup"
  echo "$gather"
fi
