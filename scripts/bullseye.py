#!/usr/bin/env python3
"""The MPEG-7 bullseye score of a `vorl similarity --format json` matrix.

Each shape is a query against every shape (itself included): the 40 nearest by f' (the row's
values: the query matched as the part against each as the template) are its hits, and the
score is the share of same-class shapes among them, out of the 20 each class has. Classes are
the file stems before their last '-' (MPEG-7's `name-N`).

    python3 scripts/bullseye.py similarity.json
"""
import json
import sys


def bullseye(names, matrix, hits=40):
    cls = [n.rsplit("-", 1)[0] for n in names]
    per_class = {c: cls.count(c) for c in set(cls)}
    found = wanted = 0
    for i, row in enumerate(matrix):
        order = sorted(range(len(row)), key=lambda j: (row[j] if row[j] is not None else float("inf"), j))
        found += sum(1 for j in order[:hits] if cls[j] == cls[i])
        wanted += per_class[cls[i]]
    return found / wanted if wanted else 0.0


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: bullseye.py SIMILARITY.json")
    with open(sys.argv[1]) as f:
        d = json.load(f)
    score = bullseye(d["names"], d["matrix"])
    print(f"bullseye {100 * score:.1f} % ({len(d['names'])} shapes, top 40)")


if __name__ == "__main__":
    main()
