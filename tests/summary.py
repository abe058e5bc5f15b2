#!/usr/bin/env python3
"""The closing lines of ./pl test, from ctest's JUnit files (ctest --output-junit FILE).

    python3 tests/summary.py FILE.xml...

Prints the tests skipped and why, the 15 slowest, then one line "tests: N passed, N failed, N skipped".
Exits 1 when a test failed, or when a file is missing or holds no test (a skip is counted, not failed).
"""
import sys
import xml.etree.ElementTree as ET


def skip_reason(case):
    """GoogleTest's message after its "Skipped" line, or what ctest says."""
    out = (case.findtext("system-out") or "").splitlines()
    for i, line in enumerate(out):
        if line.endswith(": Skipped") and i + 1 < len(out):
            return out[i + 1].strip()
    why = case.find("skipped")
    return (why.get("message") if why is not None else None) or case.get("status") or "?"


def main(paths):
    passed, failed, skipped, slow, problems = 0, [], [], [], []
    for path in paths:
        try:
            cases = ET.parse(path).getroot().iter("testcase")
        except (OSError, ET.ParseError) as e:
            problems.append(f"{path}: {e}")
            continue
        run_here = 0
        for case in cases:
            run_here += 1
            name, seconds = case.get("name", "?"), float(case.get("time") or 0)
            slow.append((seconds, name, path))
            if case.find("skipped") is not None or case.get("status") in ("notrun", "disabled"):
                skipped.append((name, skip_reason(case)))
            elif case.find("failure") is not None or case.get("status") == "fail":
                failed.append(name)
            else:
                passed += 1
        if run_here == 0:
            problems.append(f"{path}: no test ran")
    for name, why in skipped:
        print(f"skipped: {name} ({why})")
    print("the 15 slowest tests:")
    for seconds, name, path in sorted(slow, reverse=True)[:15]:
        print(f"  {seconds:7.1f} s  {name}")
    for name in failed:
        print(f"failed: {name}")
    for p in problems:
        print(f"error: {p}")
    print(f"tests: {passed} passed, {len(failed)} failed, {len(skipped)} skipped")
    return 1 if failed or problems else 0


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1:]))
