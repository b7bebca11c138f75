"""pdmkit designer: explore an ensemble, design indicators, rank, train and export.

``pdmkit designer`` starts a local web app (bound to 127.0.0.1, a free port) that
works through the steps of an interactive feature designer: look at the members and
their signals by condition, compute indicators, rank them, train a classifier, and
export the work as a command line, a Python script and a fitted pipeline.

This module stays light (the command line imports it to register the command); the web
app is imported when it starts.
"""

from pdmkit.experiments.designer._command import add_parser

__all__ = ["add_parser"]
