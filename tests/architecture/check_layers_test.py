"""scripts/check-layers.py fails on each kind of violation, and passes a clean tree.

Builds small git repositories in temporary folders, each with one planted violation, runs the
check on them (--root) and compares its exit status and lines. Standard library only:
  python3 tests/architecture/check_layers_test.py
"""
import os
import pathlib
import subprocess
import sys
import tempfile
import unittest

SCRIPT = pathlib.Path(__file__).resolve().parents[2] / "scripts" / "check-layers.py"


def check(files, *flags):
    """Exit status and output lines of the check on a repository holding `files`."""
    with tempfile.TemporaryDirectory() as root:
        for path, text in files.items():
            target = pathlib.Path(root, path)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(text)
        subprocess.run(["git", "init", "-q", root], check=True)
        subprocess.run(["git", "-C", root, "add", "."], check=True)
        result = subprocess.run([sys.executable, str(SCRIPT), "--root", root, *flags],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        return result.returncode, result.stdout.splitlines()


CLEAN = {
    "base/errors.h": "#pragma once\n",
    "modeling/model.h": '#pragma once\n#include "base/errors.h"\n',
    "modeling/model.cpp": '#include "modeling/model.h"\n',
    "servokit/servokit.h": '#pragma once\n#include "base/errors.h"\n',
    "application/main.cpp": '#include "servokit/servokit.h"\n',
    "tests/anything_test.cpp": '#include "application/main.h"\n#include "base/errors.h"\n',
}


class CheckLayersTest(unittest.TestCase):
    def test_a_clean_tree_passes(self):
        self.assertEqual(check(CLEAN), (0, []))

    def test_an_include_from_a_lower_layer_into_a_higher_one_fails(self):
        files = dict(CLEAN, **{"base/errors.h": '#pragma once\n#include "modeling/model.h"\n'})
        status, lines = check(files, "--without-front-door")
        self.assertEqual(status, 1)
        self.assertIn('base/errors.h:2: #include "modeling/model.h": base/ may not include '
                      "modeling/, a higher layer", lines)

    def test_an_include_sideways_within_a_layer_fails(self):
        files = dict(CLEAN, **{"files/input_file.cpp": '#include "numerics/finite.h"\n',
                               "numerics/finite.h": "#pragma once\n"})
        status, lines = check(files)
        self.assertEqual(status, 1)
        self.assertIn('files/input_file.cpp:1: #include "numerics/finite.h": files/ may not '
                      "include numerics/, beside it in the same layer", lines)

    def test_two_units_that_include_each_other_fail(self):
        files = dict(CLEAN, **{"solvers/a.h": "#pragma once\n",
                               "solvers/a.cpp": '#include "solvers/a.h"\n#include "solvers/b.h"\n',
                               "solvers/b.h": '#pragma once\n#include "solvers/a.h"\n'})
        status, lines = check(files)
        self.assertEqual(status, 1)
        self.assertEqual(sorted(lines), [
            'solvers/a.cpp:2: #include "solvers/b.h": units solvers/a, solvers/b include '
            "each other",
            'solvers/b.h:2: #include "solvers/a.h": units solvers/a, solvers/b include each other',
        ])

    def test_a_longer_circle_fails_once_naming_its_units(self):
        files = dict(CLEAN, **{"analysis/a.h": '#pragma once\n#include "analysis/b.h"\n',
                               "analysis/b.h": '#pragma once\n#include "analysis/c.h"\n',
                               "analysis/c.h": '#pragma once\n#include "analysis/a.h"\n'})
        status, lines = check(files)
        self.assertEqual(status, 1)
        self.assertEqual(lines, ['analysis/c.h:2: #include "analysis/a.h": closes the circle '
                                 "analysis/a -> analysis/b -> analysis/c -> analysis/a (3 units "
                                 "in circles with each other)"])

    def test_the_application_uses_only_the_front_door_unless_switched_off(self):
        files = dict(CLEAN, **{"application/main.cpp": '#include "modeling/model.h"\n'})
        status, lines = check(files)
        self.assertEqual(status, 1)
        self.assertEqual(lines, ['application/main.cpp:1: #include "modeling/model.h": '
                                 "application/ includes only servokit/servokit.h and its own "
                                 "headers"])
        self.assertEqual(check(files, "--without-front-door"), (0, []))

    def test_code_in_a_folder_of_no_layer_fails(self):
        files = dict(CLEAN, **{"models/loader.cpp": '#include "base/errors.h"\n'})
        status, lines = check(files)
        self.assertEqual(status, 1)
        self.assertEqual(len(lines), 1)
        self.assertTrue(lines[0].startswith("models/loader.cpp:1: in no layer"))


if __name__ == "__main__":
    os.environ.setdefault("GIT_CONFIG_NOSYSTEM", "1")
    unittest.main()
