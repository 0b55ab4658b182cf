"""``python -m hvacflex``: the same command line as the ``hvacflex`` script.

Importing this module runs nothing (only ``python -m hvacflex`` does)."""

from hvacflex.cli import app

if __name__ == "__main__":
    app(prog_name="hvacflex")
