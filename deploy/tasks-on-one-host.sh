#!/usr/bin/env bash
# A fleet given errands from the command line, every program a process of
# its own on one host, all meeting through `rome router`: the data server,
# `rome sim` with N robots at real time, for each robot its navigator,
# ctracker, mapper and `planner --tasks`, and one dispatcher. Adds M tasks
# with `rome task add`, waits until every task has ended, and prints how
# many were done, the wall time, the CPU time of all the processes, their
# peak resident memory and the host's load.
#
#   deploy/tasks-on-one-host.sh [N] [M] [-- extra rome sim flags]
#
# N robots (default 10, at most 10) start at the FROM positions of
# maps/data/eb3.routes; the tasks go to its TO positions, in turn. ROME
# (default `rome`) names the binary, PORT (default 7447) the router's
# port, LOGS (default a new temporary directory) where every process's
# output goes, LIMIT (default 3600) the longest wait for the tasks, s.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
rome=${ROME:-rome}
port=${PORT:-7447}
limit=${LIMIT:-3600}
logs=${LOGS:-$(mktemp -d -t rome-tasks-XXXXXX)}
mkdir -p "$logs"
n=${1:-10}
m=${2:-20}
shift 2 || shift $# || true
[ "${1:-}" = "--" ] && shift
extra=("$@")
mapfile -t lines < <(grep -v '^#' "$here/maps/data/eb3.routes" | grep -v '^[[:space:]]*$')
[ "$n" -ge 1 ] && [ "$n" -le "${#lines[@]}" ] ||
    { echo "error: N must be 1 to ${#lines[@]} (the lines of eb3.routes), got $n" >&2; exit 2; }
[ "$m" -ge 1 ] || { echo "error: M must be at least 1, got $m" >&2; exit 2; }
from=() to=()
for l in "${lines[@]}"; do
    read -r a b <<<"$l"
    from+=("$a")
    to+=("$b")
done
at=$(IFS=,; echo "${from[*]:0:$n}")

net=(--no-multicast -m client -e "tcp/127.0.0.1:$port")
# shellcheck source=one-host.sh
. "$here/deploy/one-host.sh"
spawn() { # NAME ARGS…: a rome process in the background, its output in NAME.log
    local name=$1
    shift
    "$rome" "$@" >"$logs/$name.log" 2>&1 &
    pids+=($!)
}

start=$(date +%s.%N)
spawn router --no-multicast -l "tcp/127.0.0.1:$port" router --in-memory --rest-port none
sleep 1
spawn data-server "${net[@]}" data-server --in-memory
spawn sim "${net[@]}" sim --robots "$n" --at "$at" "${extra[@]}"
for k in $(seq 1 "$n"); do
    for c in navigator ctracker mapper; do
        spawn "$c-r$k" "${net[@]}" "$c" --robot "r$k"
    done
    spawn "planner-r$k" "${net[@]}" planner --robot "r$k" --from "${from[$((k - 1))]}" --tasks
done
spawn dispatcher "${net[@]}" dispatcher

# Every robot takes tasks before the first is added, so each task goes to
# the nearest of all of them.
task() { "$rome" "${net[@]}" task "$@"; }
for _ in $(seq 1 120); do
    ready=$(task robots 2>/dev/null | grep -c ' idle ' || true)
    [ "$ready" -ge "$n" ] && break
    sleep 1
done
[ "${ready:-0}" -ge "$n" ] ||
    { echo "error: only ${ready:-0} of $n robots take tasks after 120 s; logs: $logs" >&2; exit 1; }
echo "$n robots take tasks; adding $m"
for j in $(seq 1 "$m"); do
    task add --to "${to[$(((j - 1) % n))]}" >/dev/null
done

# Wait for every task to end, with a line whenever the count changes.
ended=0
deadline=$(($(date +%s) + limit))
while [ "$(date +%s)" -lt "$deadline" ]; do
    task ls --json >"$logs/tasks.json" 2>/dev/null || true
    now=$(grep -c -E '"state":"(done|failed|cancelled)"' "$logs/tasks.json" || true)
    if [ "$now" != "$ended" ]; then
        ended=$now
        printf '%s: %d of %d tasks ended\n' "$(date +%T)" "$ended" "$m"
    fi
    [ "$ended" -ge "$m" ] && break
    sleep 2
done
end=$(date +%s.%N)
done_=$(grep -c '"state":"done"' "$logs/tasks.json" || true)
load=$(cut -d' ' -f1-3 /proc/loadavg)
task ls >"$logs/tasks.txt" 2>&1 || true

stop_and_measure
cat "$logs/tasks.txt"
printf 'robots: %d; tasks done: %d of %d; processes: %d; wall: %.0f s; CPU (all processes): %.0f s; peak memory: %d MiB; load (1, 5, 15 min): %s; logs: %s\n' \
    "$n" "$done_" "$m" "${#pids[@]}" "$(echo "$end - $start" | bc)" "$cpu_s" "$rss_mib" "$load" "$logs"
[ "$done_" -eq "$m" ] || { echo "error: $((m - done_)) task(s) not done" >&2; exit 1; }
