#!/usr/bin/env python3
"""Mean CPU time (user + system, ms) of a command run REPEAT times: `child_cpu.py REPEAT CMD...`.

Measured with getrusage(RUSAGE_CHILDREN) around the runs (microsecond resolution), so the
process's whole life counts: dynamic loading, static initialisers, the work and exit. Output is
discarded. Prints one number."""
import resource
import subprocess
import sys


def main():
    repeat = int(sys.argv[1])
    command = sys.argv[2:]
    subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    for _ in range(repeat):
        subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    print("%.2f" % (1000.0 * cpu / repeat))


if __name__ == "__main__":
    main()
