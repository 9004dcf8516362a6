"""`deformesh` (and `python -m deformesh`): the command line, the same
program as the Rust binary, run in this process."""

import sys

from ._deformesh import main as _main


def main() -> None:
    sys.exit(_main(["deformesh", *sys.argv[1:]]))


if __name__ == "__main__":
    main()
