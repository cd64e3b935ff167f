#!/usr/bin/env python3
"""The layer rule of shared/docs/design.md: a room's headers include only rooms listed before it
(or itself). Fails naming every include that points down the list.

    layers_test.py INCLUDE_DIR
"""
import os
import re
import sys

ORDER = ["core", "geometry", "io", "anatomy", "render", "labels", "nn", "dataset", "match",
         "metrics", "pipeline"]
root = os.path.join(sys.argv[1], "gimm")
bad = []
for room in sorted(os.listdir(root)):
    folder = os.path.join(root, room)
    if not os.path.isdir(folder):
        continue
    if room not in ORDER:
        bad.append(f"include/gimm/{room}/: a room the layer table does not list")
        continue
    for name in sorted(os.listdir(folder)):
        with open(os.path.join(folder, name)) as f:
            for n, line in enumerate(f, 1):
                m = re.match(r'\s*#\s*include\s+"gimm/([a-z_]+)/', line)
                if m and m.group(1) in ORDER and ORDER.index(m.group(1)) > ORDER.index(room):
                    bad.append(f"include/gimm/{room}/{name}:{n} includes {m.group(1)}/ "
                               f"(listed after {room}/)")
# A room's umbrella (gimm/<room>.hpp) gathers that room: the same rule.
for room in ORDER:
    umbrella = os.path.join(root, room + ".hpp")
    if not os.path.exists(umbrella):
        continue
    with open(umbrella) as f:
        for n, line in enumerate(f, 1):
            m = re.match(r'\s*#\s*include\s+"gimm/([a-z_]+)/', line)
            if m and m.group(1) in ORDER and ORDER.index(m.group(1)) > ORDER.index(room):
                bad.append(f"include/gimm/{room}.hpp:{n} includes {m.group(1)}/ "
                           f"(listed after {room}/)")
print("\n".join(bad) if bad else "layers: every include points up the table")
sys.exit(1 if bad else 0)
