"""setuptools' build backend, without its notice on every editable install.

The repository root *is* the package (``package-dir = {"pdmkit" = "."}``, fixed by the
project's layout), so setuptools installs it in editable mode through a meta-path
finder and says so in an "Editable installation" notice box (an ``InformationOnly``
warning: nothing to act on). Everything else is ``setuptools.build_meta`` unchanged;
real setuptools warnings still show.
"""

import warnings

from setuptools.build_meta import *  # noqa: F403  (the PEP 517 hooks, unchanged)
from setuptools.build_meta import __all__  # noqa: F401
from setuptools.warnings import InformationOnly

warnings.filterwarnings("ignore", category=InformationOnly)
