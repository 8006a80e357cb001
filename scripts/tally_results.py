#!/usr/bin/env python3
"""Tallies JUnit XML test results under a folder: prints failures, then 'N passed, N failed[, N skipped]'.

gtest writes one file per test binary; rostest writes a summary file per launch file
(rostest-*.xml) plus one file per test node. Test cases are counted from the per-node files;
a rostest summary only adds a failure when a test node died without writing its own results.
Exits non-zero when anything failed.
"""
import pathlib
import sys
import xml.etree.ElementTree as ElementTree


def main():
    root = pathlib.Path(sys.argv[1])
    skipped = int(sys.argv[2]) if len(sys.argv) > 2 else 0
    passed = failed = 0
    for path in sorted(root.rglob("*.xml")):
        try:
            tree = ElementTree.parse(path)
        except ElementTree.ParseError as error:
            print(f"FAILED {path}: unreadable result file ({error})")
            failed += 1
            continue
        summary = path.name.startswith("rostest-")
        for case in tree.iter("testcase"):
            name = f"{case.get('classname', '')}.{case.get('name', '')}"
            problem = case.find("failure")
            if problem is None:
                problem = case.find("error")
            if case.find("skipped") is not None or case.get("result") == "skipped" or case.get("status") == "notrun":
                skipped += 1
            elif problem is not None:
                failed += 1
                print(f"FAILED {name}: {(problem.get('message') or problem.text or '').strip()[:300]}")
            elif not summary:
                passed += 1
    line = f"{passed} passed, {failed} failed"
    if skipped:
        line += f", {skipped} skipped"
    print(line)
    return 1 if failed or passed == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
