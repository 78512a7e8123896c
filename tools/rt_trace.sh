#!/bin/bash
# Kernel trace of one `mesopush-executor bench` run: which thread held the loop's CPU when the
# loop woke late. Needs root and debugfs (mounted here if it is not).
# Usage: tools/rt_trace.sh OUT_PREFIX [bench options...]
#   e.g. tools/rt_trace.sh /tmp/rt1 --seconds 20 --hog --rt-priority 80 --pin-cpu 1
# Writes OUT_PREFIX.json (the bench's figures), OUT_PREFIX.tasks (thread ids; the first is the
# loop), OUT_PREFIX.trace (the raw trace); then prints tools/rt_trace_report.py's summary.
set -eu
out=$1; shift
exe=${EXE:-$(dirname "$0")/../target/release/mesopush-executor}
T=/sys/kernel/debug/tracing
[ -d $T ] || mount -t debugfs none /sys/kernel/debug
events="sched/sched_switch sched/sched_wakeup timer/hrtimer_start timer/hrtimer_expire_entry"
echo 0 > $T/tracing_on
echo 80000 > $T/buffer_size_kb
echo > $T/trace
for e in $events; do echo 1 > $T/events/$e/enable; done
echo 1 > $T/tracing_on
"$exe" bench --json "$@" > "$out.json" &
pid=$!
sleep 2
for t in /proc/$pid/task/*; do echo "$(basename "$t") $(cat "$t/comm")"; done > "$out.tasks"
wait $pid || true
echo 0 > $T/tracing_on
cat $T/trace > "$out.trace"
for e in $events; do echo 0 > $T/events/$e/enable; done
python3 "$(dirname "$0")/rt_trace_report.py" "$out"
