"""``python -m twin.cli``: the ``twin`` command."""

from twin.cli import console

if __name__ == "__main__":  # importing the module (the API reference does) must not run the CLI
    console()
