#!/usr/bin/env python3
"""The architecture check (docs/development.md, "Layout: the folders are the layers").

Reads every `#include "..."` of the git-tracked *.cpp and *.h files and fails, with one line per
violation (file:line: the include: why), on
  (a) an include from a folder into a folder of the same or a higher layer (LAYERS, lowest
      first; tests/ and bench/ may include anything);
  (b) a circle of units (a .h and its .cpp are one unit): two units that include each other, or
      a longer round, across or inside folders;
  (c) a file of application/ including anything but servokit/servokit.h and application/'s own
      headers: the one front door. --without-front-door skips this rule.
Exit status: 0 clean, 1 violations, 2 usage.

  scripts/check-layers.py [--without-front-door] [--root DIR]
"""
import argparse
import collections
import os
import re
import subprocess
import sys

# The layers, lowest first; the folders of one layer may not include each other.
LAYERS = [
    ["base"],
    ["files", "numerics"],
    ["modeling"],
    ["analysis", "trajectories"],
    ["integrators"],
    ["solvers"],
    ["reports"],
    ["studies"],
    ["servokit"],
    ["application"],
]
# Folders outside the layers whose code may include any layer.
UNLAYERED = {"tests", "bench"}
FRONT_DOOR = "servokit/servokit.h"
INCLUDE = re.compile(r'\s*#\s*include\s+"([^"]+)"')


def layer_of(folder):
    for rank, folders in enumerate(LAYERS):
        if folder in folders:
            return rank
    return None


def tracked_sources(root):
    listing = subprocess.run(
        ["git", "-C", root, "ls-files", "-z", "--", "*.cpp", "*.h"],
        check=True, stdout=subprocess.PIPE).stdout.decode()
    return sorted(path for path in listing.split("\0") if path)


def read_includes(root, path):
    """The quoted includes of `path` as (line number, text as written, repository path)."""
    includes = []
    with open(os.path.join(root, path), encoding="utf-8", errors="replace") as source:
        for number, line in enumerate(source, start=1):
            match = INCLUDE.match(line)
            if not match:
                continue
            written = match.group(1)
            resolved = written
            # Includes are written from the repository root; a relative one resolves beside
            # the file that writes it.
            if not os.path.exists(os.path.join(root, written)):
                beside = os.path.normpath(os.path.join(os.path.dirname(path), written))
                if os.path.exists(os.path.join(root, beside)):
                    resolved = beside
            includes.append((number, written, resolved))
    return includes


def unit_of(path):
    return os.path.splitext(path)[0]


def folder_of(path):
    return path.split("/", 1)[0] if "/" in path else ""


def check_layers(path, includes):
    folder = folder_of(path)
    if folder in UNLAYERED:
        return []
    rank = layer_of(folder)
    if rank is None:
        return [f"{path}:1: in no layer: its folder '{folder}/' is not in scripts/check-layers.py"]
    problems = []
    for number, written, resolved in includes:
        target = folder_of(resolved)
        if target == folder:
            continue
        target_rank = layer_of(target)
        if target_rank is None:
            problems.append(f'{path}:{number}: #include "{written}": {target or "."}/ is no layer')
        elif target_rank > rank:
            problems.append(f'{path}:{number}: #include "{written}": {folder}/ may not include '
                            f"{target}/, a higher layer")
        elif target_rank == rank:
            problems.append(f'{path}:{number}: #include "{written}": {folder}/ may not include '
                            f"{target}/, beside it in the same layer")
    return problems


def check_front_door(path, includes):
    if folder_of(path) != "application":
        return []
    return [f'{path}:{number}: #include "{written}": application/ includes only '
            f"{FRONT_DOOR} and its own headers"
            for number, written, resolved in includes
            if resolved != FRONT_DOOR and folder_of(resolved) != "application"]


def circles(edges):
    """The strongly connected components of more than one unit (Tarjan, iterative)."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []
    counter = 0
    for start in sorted(edges):
        if start in index:
            continue
        work = [(start, iter(sorted(edges.get(start, ()))))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            unit, successors = work[-1]
            advanced = False
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = counter
                    counter += 1
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(edges.get(successor, ())))))
                    advanced = True
                    break
                if successor in on_stack:
                    low[unit] = min(low[unit], index[successor])
            if advanced:
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[unit])
            if low[unit] == index[unit]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == unit:
                        break
                if len(component) > 1:
                    found.append(set(component))
    return found


def shortest_circle(edges, component):
    """The units of a shortest circle through the first unit of `component`, that unit first."""
    start = min(component)
    parent = {start: None}
    queue = collections.deque([start])
    while queue:
        unit = queue.popleft()
        for successor in sorted(edges.get(unit, ())):
            if successor == start:
                path = [unit]
                while parent[path[-1]] is not None:
                    path.append(parent[path[-1]])
                return list(reversed(path))
            if successor in component and successor not in parent:
                parent[successor] = unit
                queue.append(successor)
    return [start]


def check_circles(all_includes):
    """Two units that include each other: a line for each of the two includes. A longer circle
    (none of whose units include each other): one line, for the include that closes a shortest
    circle through it, naming its units."""
    edges = collections.defaultdict(set)
    for path, includes in all_includes.items():
        for _, _, resolved in includes:
            if unit_of(resolved) != unit_of(path):
                edges[unit_of(path)].add(unit_of(resolved))

    def includes_between(source, target):
        return [(path, number, written)
                for path, includes in sorted(all_includes.items()) if unit_of(path) == source
                for number, written, resolved in includes if unit_of(resolved) == target]

    problems = []
    for component in circles(edges):
        pairs = sorted((first, second) for first in component for second in component
                       if first < second and second in edges[first] and first in edges[second])
        for first, second in pairs:
            for source, target in ((first, second), (second, first)):
                for path, number, written in includes_between(source, target):
                    problems.append(f'{path}:{number}: #include "{written}": units {first}, '
                                    f"{second} include each other")
        if pairs:
            continue  # the longer circles through them show once the pairs are broken
        circle = shortest_circle(edges, component)
        path, number, written = includes_between(circle[-1], circle[0])[0]
        problems.append(f'{path}:{number}: #include "{written}": closes the circle '
                        f'{" -> ".join(circle + [circle[0]])} ({len(component)} units in circles '
                        "with each other)")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--without-front-door", action="store_true",
                        help="skip rule (c): application/ may include any lower layer")
    parser.add_argument("--root", default=None,
                        help="the repository (default: the one holding this script)")
    arguments = parser.parse_args()
    root = arguments.root or os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

    all_includes = {path: read_includes(root, path) for path in tracked_sources(root)}
    problems = []
    for path, includes in all_includes.items():
        problems += check_layers(path, includes)
        if not arguments.without_front_door:
            problems += check_front_door(path, includes)
    problems += check_circles(all_includes)
    for problem in problems:
        print(problem)
    if problems:
        print(f"check-layers: {len(problems)} violation(s) of the layers "
              "(docs/development.md, \"Layout: the folders are the layers\")", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
