#!/usr/bin/env python3
"""Summary of a tools/rt_trace.sh run: for the executor loop's thread (the first of
PREFIX.tasks), each timer wake-up's lateness (timer expiry after its due time) and its
wake-to-run delay (expiry to the switch into the loop), the five worst of each, and what ran
on the loop's CPU meanwhile. Usage: rt_trace_report.py PREFIX"""
import collections
import json
import re
import sys

prefix = sys.argv[1]
loop = open(prefix + '.tasks').readline().split()[0]
line_re = re.compile(r'^\s*(.+?)-(\d+)\s+\[(\d+)\]\s+\S+\s+([\d.]+): (\w+): (.*)$')
armed = {}      # hrtimer address -> due time (ns), for the loop's sleeps
pending = None  # (trace time of the expiry, lateness ns)
wakes = []      # (lateness µs, wake-to-run µs, trace time, cpu)
runs = collections.defaultdict(list)  # cpu -> [(time, comm, pid, prio)] at each switch
for line in open(prefix + '.trace'):
    m = line_re.match(line)
    if not m:
        continue
    _, pid, cpu, t, event, rest = m.groups()
    t, cpu = float(t), int(cpu)
    f = dict(re.findall(r'(\w+)=(\S+)', rest))
    if event == 'hrtimer_start' and pid == loop and f.get('function') == 'hrtimer_wakeup':
        armed[f['hrtimer']] = int(f['expires'])
    elif event == 'hrtimer_expire_entry' and f.get('hrtimer') in armed:
        pending = (t, int(f['now']) - armed.pop(f['hrtimer']))
    elif event == 'sched_switch':
        runs[cpu].append((t, f['next_comm'], f['next_pid'], f['next_prio']))
        if f['next_pid'] == loop and pending:
            wakes.append((pending[1] / 1e3, (t - pending[0]) * 1e6, pending[0], cpu))
            pending = None


def occupants(cpu, t0, t1):
    """Who ran on `cpu` between t0 and t1 (s), longest first, µs each."""
    took, prev = collections.Counter(), None
    for r in runs[cpu]:
        if r[0] > t1:
            break
        if prev and r[0] >= t0:
            took[prev[1:]] += r[0] - max(prev[0], t0)
        prev = r
    if prev and prev[0] < t1:
        took[prev[1:]] += t1 - max(prev[0], t0)
    return [(f'{c}/{p} prio {q}', round(v * 1e6)) for (c, p, q), v in took.most_common(3)]


try:
    bench = json.load(open(prefix + '.json'))
    print(f"trial: {bench['trial_end']}; loop late max {bench['shell_max_late_us']} µs; "
          f"send p99 {bench['p99_us']} µs")
except (OSError, ValueError, KeyError):
    print('no bench figures (the run failed?)')
print(f'loop thread {loop}: {len(wakes)} timer wake-ups traced')
print('latest timer expiries (µs late, then µs to run):')
for late, run, t, cpu in sorted(wakes, key=lambda w: -w[0])[:5]:
    print(f'  {late:9.1f}  {run:9.1f}  at {t:.6f} on CPU {cpu}')
print('longest wake-to-run delays (µs), and what held the CPU:')
for late, run, t, cpu in sorted(wakes, key=lambda w: -w[1])[:5]:
    print(f'  {run:9.1f}  at {t:.6f} on CPU {cpu}:', occupants(cpu, t, t + run / 1e6))
