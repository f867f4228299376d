# Sourced by the *-on-one-host.sh scripts: the processes they start, and
# what those processes cost. Expects `logs` to name a directory.

pids=()
cleanup() { kill "${pids[@]}" 2>/dev/null || true; wait 2>/dev/null || true; }
trap cleanup EXIT

# Sums the peak resident memory of every process in `pids` (rss_mib), stops
# them, and sums the CPU time of every process the script started (cpu_s).
# It must run in the script's own shell, not a subshell: bash's `times`
# counts only the children of the shell it runs in.
stop_and_measure() {
    local rss=0 kb p
    for p in "${pids[@]}"; do
        kb=$(awk '/VmHWM/ {print $2}' "/proc/$p/status" 2>/dev/null || echo 0)
        rss=$((rss + ${kb:-0}))
    done
    rss_mib=$((rss / 1024))
    cleanup
    trap - EXIT
    times >"$logs/times"
    cpu_s=$(tail -n 1 "$logs/times" | awk '{ split($1, u, "m"); split($2, s, "m"); sub("s", "", u[2]); sub("s", "", s[2]); print u[1] * 60 + u[2] + s[1] * 60 + s[2] }')
}
