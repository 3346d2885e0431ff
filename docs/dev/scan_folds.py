#!/usr/bin/env python3
"""Which cases of a foreign-suite debug log the held-out fold rule of 43a91f5 can reach.

Usage: python3 docs/dev/scan_folds.py LOG [LOG...]

LOG is the stderr of `RUST_LOG=geared_servo_host::diagnose=debug <diagnose_foreign binary>
--ignored --nocapture diagnose_names_effects` (or a docs/dev log that kept its `fold:` lines).
The rule (`judge::held_out`) keeps a fold's refit only where it lowers the fold's cost by more
than one unit of chi-square over the fold's weighted rows, always more than 100: a case none
of whose fold lines drops its train cost by less than 1 % runs bit-identically with and
without the rule. Prints those that have such a line (to rerun), with their lines.
"""
import re
import sys

RESULT = re.compile(r'^(\S+/\d+)\s+(RIGHT|WRONG)')
FOLD = re.compile(r'fold: (\S+) (\S+) refitted to (\S+); train (\S+) -> (\S+),')

for fn in sys.argv[1:]:
    flagged, cur = [], []
    for line in open(fn):
        m = FOLD.search(line)
        if m:
            a, b = float(m.group(4)), float(m.group(5))
            if a > 0 and (a - b) / a < 1e-2:
                cur.append((m.group(1), float(m.group(2)), float(m.group(3)), a, b))
            continue
        m = RESULT.match(line)
        if m:
            if cur:
                flagged.append((m.group(1), m.group(2), cur))
            cur = []
    print(f"{fn}: {len(flagged)} cases the rule can reach")
    for case, verdict, lines in flagged:
        print(f"  {case} {verdict} {len(lines)} lines, e.g. {lines[0]}")
