#!/usr/bin/env python3
"""Where a firmware's instructions went: the QEMU plugin's profile (address, executions) mapped to
roadvo's source files through the ELF's line tables (inlined code included: each address is put
down to the innermost roadvo source file of its inline chain), then to the method's stages.

Usage: firmware-profile.py ELF PROFILE. Prints one line: ground corners, the image heading, the vote, the rest, in % of all
instructions the run executed (the frames are nearly all of it: the boot and the log lines are
well under 1 %)."""
import collections
import os
import subprocess
import sys

elf, profile = sys.argv[1:]
# roadvo's own sources (not the standard library's library/core/src).
ours = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "core", "src") + "/"
counts = {}
for line in open(profile):
    addr, n = line.split()
    counts[int(addr, 16)] = int(n)
addrs = sorted(counts)
out = subprocess.run(
    ["arm-none-eabi-addr2line", "-e", elf, "-i", "-a"] + [hex(a) for a in addrs],
    capture_output=True, text=True, check=True).stdout.splitlines()

# addr2line -a -i: each address on a line of its own, then one file:line per inline level.
chains = {}
current = None
for line in out:
    if line.startswith("0x"):
        current = int(line, 16)
        chains[current] = []
    elif current is not None:
        chains[current].append(line)


def stage(chain):
    """The stage of the innermost roadvo source file in the chain."""
    for loc in chain:
        if not loc.startswith(ours):
            continue
        path = loc[len(ours):].split(":")[0]
        if path == "harris.rs":
            return "detection", path
        if path.startswith("heading/"):
            return "heading", path
        if path == "vote.rs" or path.startswith("method/"):
            return "vote", path
        return "rest", path
    return "rest", "(outside roadvo: libm, compiler_builtins, the firmware)"


total = sum(counts.values())
by_stage = collections.Counter()
by_file = collections.Counter()
for a, n in counts.items():
    s, f = stage(chains.get(a, []))
    by_stage[s] += n
    by_file[f] += n
pct = lambda n: 100.0 * n / max(total, 1)
print("where the instructions go: ground corners (harris.rs) {:.1f} %, image heading (heading/) "
      "{:.1f} %, vote (vote.rs, method/) {:.1f} %, rest {:.1f} %".format(
          pct(by_stage["detection"]), pct(by_stage["heading"]), pct(by_stage["vote"]),
          pct(by_stage["rest"])))
top = ", ".join("{} {:.1f} %".format(f, pct(n)) for f, n in by_file.most_common(6))
print("  by file: " + top)
