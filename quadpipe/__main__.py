"""`python -m quadpipe` runs the command line."""

from quadpipe.cli import main

main()
