"""``python -m volpack`` runs the command-line interface (through a listening server
where one may run the command: :mod:`volpack.launch`)."""

from volpack.launch import run

if __name__ == "__main__":
    run()
