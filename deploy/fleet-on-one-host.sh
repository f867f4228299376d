#!/usr/bin/env bash
# Several robots with every navigation client in its own process, on one
# host: a data server, `rome sim` with N robots, and for each robot its
# navigator, ctracker, mapper, plfinder and planner. Waits for every planner,
# prints each one's row and last line, then the whole run's wall time, the
# CPU time of all its processes and their peak resident memory.
#
#   deploy/fleet-on-one-host.sh [ROUTES_FILE] [-- extra rome sim flags]
#
# ROUTES_FILE has one `FROM TO` a line (robot k drives line k; default: the
# first three of maps/data/eb3.routes). ROME (default `rome`) names the
# binary, PORT (default 7447) the data server's port, LOGS (default a new
# temporary directory) where every process's output goes.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
rome=${ROME:-rome}
port=${PORT:-7447}
logs=${LOGS:-$(mktemp -d -t rome-fleet-XXXXXX)}
mkdir -p "$logs"
routes=${1:-}
shift || true
[ "${1:-}" = "--" ] && shift
if [ -z "$routes" ]; then
    routes="$logs/routes"
    grep -v '^#' "$here/maps/data/eb3.routes" | grep -v '^$' | head -n 3 >"$routes"
fi
mapfile -t lines < <(grep -v '^#' "$routes" | grep -v '^[[:space:]]*$')
n=${#lines[@]}
[ "$n" -gt 0 ] || { echo "error: no routes in $routes" >&2; exit 2; }
at=$(for l in "${lines[@]}"; do set -- $l; printf '%s,' "$1"; done)
at=${at%,}

net=(--no-multicast -e "tcp/127.0.0.1:$port")
# shellcheck source=one-host.sh
. "$here/deploy/one-host.sh"

start=$(date +%s.%N)
# A simulated run starts from nothing: its state need not outlive it.
"$rome" --no-multicast -l "tcp/127.0.0.1:$port" data-server --in-memory >"$logs/data-server.log" 2>&1 &
pids+=($!)
"$rome" "${net[@]}" -l tcp/127.0.0.1:0 -m peer sim --robots "$n" --at "$at" "$@" >"$logs/sim.log" 2>&1 &
pids+=($!)
for k in $(seq 1 "$n"); do
    for c in navigator ctracker mapper plfinder; do
        "$rome" "${net[@]}" "$c" --robot "r$k" >"$logs/$c-r$k.log" 2>&1 &
        pids+=($!)
    done
done
planners=()
for k in $(seq 1 "$n"); do
    set -- ${lines[$((k - 1))]}
    "$rome" "${net[@]}" planner --robot "r$k" --from "$1" --to "$2" >"$logs/planner-r$k.log" 2>&1 &
    planners+=($!)
done
failed=0
for k in $(seq 1 "$n"); do
    wait "${planners[$((k - 1))]}" || failed=$((failed + 1))
done
end=$(date +%s.%N)

# Peak memory of the servers and helpers, then stop them: bash's `times`
# then holds the CPU time of every process the script started.
stop_and_measure
for k in $(seq 1 "$n"); do
    grep -h -E '^[0-9]+ +r[0-9]+ ' "$logs/planner-r$k.log" || true
done
for k in $(seq 1 "$n"); do
    tail -n 1 "$logs/planner-r$k.log"
done
printf 'robots: %d; processes: %d; wall: %.1f s; CPU (all processes): %.1f s; peak memory of the servers and helpers: %d MiB; logs: %s\n' \
    "$n" $((${#pids[@]} + n)) "$(echo "$end - $start" | bc)" "$cpu_s" "$rss_mib" "$logs"
[ "$failed" -eq 0 ] || { echo "error: $failed planner(s) did not arrive" >&2; exit 1; }
