"""``python -m xgo_show`` runs the CLI."""

from xgo_show.cli.main import program

program()
