"""The examples of README.md and docs/*.md are run, and their output must be what the page shows
(issue #30; the conventions are in docs/development.md, "Examples are tests").

Each page runs in a fresh scratch directory that holds links to the repository's models/ and
tests/, so that the pages' relative paths work as from the repository root and nothing is
written into the repository. Its fenced blocks are taken in order:

- ```console: each line `$ command` (continued on the next line after a trailing backslash) is
  run by bash with the build's `servokit` first on PATH; the lines after it, up to the next
  `$ `, are its output, stdout and stderr together. A line `...` stands for any number of
  lines, `...` within a line for any text; `[exit status N]` ends the output of a command that
  exits with N other than 0.
- ```pycon: a Python session, run by doctest (ELLIPSIS on) with the servokit module importable;
  the page's sessions share their names.
- a block right after `<!-- file: PATH -->` is written to PATH in the scratch directory, for
  the later blocks to read (a model file, a waypoint file, samples).
- a block right after `<!-- source: PATH -->` must appear, verbatim, in the repository's file
  PATH (the C++ example, which install.consumer builds and runs).

Other blocks (synopses, MATLAB, Modelica) are not run. Two more checks: every relative link of
the pages leads to a file (and heading) of the repository, and the README lists the packages
`make deps` installs. Set SERVOKIT_BINARY to the servokit executable and PYTHONPATH to the
folder of the Python module.
"""

import doctest
import os
import pathlib
import re
import subprocess
import tempfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))
FENCE = re.compile(r"^(\s*)```(\w*)\s*$")
MARKER = re.compile(r"^\s*<!-- (file|source): (\S+) -->\s*$")
EXIT_STATUS = re.compile(r"^\[exit status (\d+)\]$")
# The whole of one command; the examples are meant to be fast.
COMMAND_TIMEOUT_S = 60


class Block:
    def __init__(self, language, text, line, marker):
        self.language, self.text, self.line, self.marker = language, text, line, marker


def blocks_of(page):
    """The fenced blocks of a page, with the marker comment right before each (or None)."""
    lines = page.read_text().split("\n")
    blocks, n = [], 0
    while n < len(lines):
        opening = FENCE.match(lines[n])
        if not opening:
            n += 1
            continue
        indent, language = opening.group(1), opening.group(2)
        marker = MARKER.match(lines[n - 1]) if n > 0 else None
        body, start = [], n + 1
        n += 1
        while n < len(lines) and lines[n].rstrip() != indent + "```":
            body.append(lines[n][len(indent):] if lines[n].startswith(indent) else lines[n])
            n += 1
        assert n < len(lines), f"{page.name}:{start}: the block is not closed"
        blocks.append(Block(language, "\n".join(body) + "\n", start,
                            marker.groups() if marker else None))
        n += 1
    return blocks


def commands_of(block):
    """(command, expected output lines) for each `$ ` line of a console block."""
    commands, lines = [], block.text.rstrip("\n").split("\n")
    n = 0
    while n < len(lines):
        assert lines[n].startswith("$ "), f"line {block.line + n}: expected `$ command`"
        command = lines[n][2:]
        while command.endswith("\\") and n + 1 < len(lines):
            n += 1
            command += "\n" + lines[n]
        expected = []
        n += 1
        while n < len(lines) and not lines[n].startswith("$ "):
            expected.append(lines[n])
            n += 1
        commands.append((command, expected))
    return commands


def pattern_of(expected):
    """A regular expression for the output `expected` shows, with its placeholders."""
    parts = []
    for line in expected:
        if line.strip() == "...":
            parts.append(r"(?:[^\n]*\n)*?")
        else:
            parts.append(r"[^\n]*".join(re.escape(piece) for piece in line.split("...")) + r"\n")
    return re.compile("".join(parts))


def run_console(block, scratch, environment, failures, page):
    for command, expected in commands_of(block):
        run = subprocess.run(["bash", "-c", command], cwd=scratch, env=environment,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             timeout=COMMAND_TIMEOUT_S)
        output = run.stdout.decode(errors="replace")
        if output and not output.endswith("\n"):
            output += "\n"
        if run.returncode != 0:
            output += f"[exit status {run.returncode}]\n"
        if not pattern_of(expected).fullmatch(output):
            failures.append(f"{page.name}:{block.line}: $ {command}\n--- the page shows:\n"
                            + "\n".join(expected) + "\n--- the command printed:\n" + output)


def run_python(block, scratch, names, failures, page):
    parser = doctest.DocTestParser()
    test = parser.get_doctest(block.text, names, page.name, str(page), block.line - 1)
    report = []
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    cwd = os.getcwd()
    os.chdir(scratch)
    try:
        runner.run(test, out=report.append, clear_globs=False)
    finally:
        os.chdir(cwd)
    names.update(test.globs)  # the doctest ran on a copy; the next session goes on from here
    if runner.failures:
        failures.append(f"{page.name}:{block.line}:\n" + "".join(report))


def environment_of_commands():
    binary = pathlib.Path(os.environ["SERVOKIT_BINARY"])
    environment = dict(os.environ)
    environment["PATH"] = f"{binary.parent}{os.pathsep}{environment.get('PATH', '')}"
    return environment


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.relative_to(ROOT).as_posix())
def test_every_example_prints_what_the_page_shows(page):
    environment, failures, names = environment_of_commands(), [], {}
    with tempfile.TemporaryDirectory(prefix="servokit-docs-") as scratch:
        for folder in ("models", "tests"):
            os.symlink(ROOT / folder, pathlib.Path(scratch) / folder)
        for block in blocks_of(page):
            if block.marker and block.marker[0] == "file":
                path = pathlib.Path(scratch) / block.marker[1]
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(block.text)
            elif block.marker and block.marker[0] == "source":
                if block.text not in (ROOT / block.marker[1]).read_text():
                    failures.append(f"{page.name}:{block.line}: not in {block.marker[1]}")
            elif block.language == "console":
                run_console(block, scratch, environment, failures, page)
            elif block.language == "pycon":
                run_python(block, scratch, names, failures, page)
    assert not failures, "\n\n".join(failures)


def anchors_of(page):
    """The anchors of a page's headings, as GitHub makes them."""
    anchors = set()
    for heading in re.findall(r"^#+ (.*)$", page.read_text(), re.MULTILINE):
        anchors.add(re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-"))
    return anchors


def test_the_pages_link_only_inside_the_repository():
    """Relative links lead to files of the repository, and to headings there; none leaves it."""
    link = re.compile(r"\]\(([^)\s]*)\)")
    for page in PAGES:
        assert "../shared" not in page.read_text(), page.name
        for target in link.findall(page.read_text()):
            if re.match(r"[a-z]+://", target):
                continue
            path, _, anchor = target.partition("#")
            resolved = (page.parent / path).resolve() if path else page
            assert ROOT in resolved.parents, f"{page.name}: {target} leaves the repository"
            assert resolved.exists(), f"{page.name}: {target} does not exist"
            if anchor:
                assert anchor in anchors_of(resolved), f"{page.name}: no heading for {target}"


def test_the_readme_lists_the_packages_make_deps_installs():
    makefile = (ROOT / "Makefile").read_text()
    listed = re.search(r"^PACKAGES := ((?:.*\\\n)*.*)$", makefile, re.MULTILINE).group(1)
    packages = listed.replace("\\\n", " ").split()
    readme = (ROOT / "README.md").read_text()
    shown = re.search(r"It needs these Debian packages:\n\n```\n(.*?)```", readme, re.DOTALL)
    assert shown, "README.md: no list of packages"
    assert shown.group(1).split() == packages
