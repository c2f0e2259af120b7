"""The Python tests as one ctest test: exit 77 (skipped) when numpy, cffi or pytest is missing,
else pytest's exit status (5, no tests collected, is a failure). Writes nothing in the tree."""
import os
import sys

try:
    import cffi  # noqa: F401
    import numpy  # noqa: F401
    import pytest
except ImportError as e:
    print(f"python_tests skipped: {e} (scripts/deps.sh --test installs python3-numpy, python3-cffi, python3-pytest)")
    sys.exit(77)

sys.dont_write_bytecode = True
sys.exit(pytest.main(["-q", "-p", "no:cacheprovider", os.path.dirname(os.path.abspath(__file__))]))
