"""``python -m volpack`` runs the command-line interface."""

from volpack.cli import main

if __name__ == "__main__":
    main()
