"""``python -m volpack`` runs the command-line interface."""

from volpack.cli import run

if __name__ == "__main__":
    run()
