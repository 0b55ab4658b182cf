"""``python -m hvacflex``: the same command line as the ``hvacflex`` script."""

from hvacflex.cli import app

app(prog_name="hvacflex")
