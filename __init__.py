"""The root folder of an avhear clone, standing in for the ``avhear`` package inside it.

Python reaches this file only when the clone's parent folder is on ``sys.path`` ahead of the installed package (a
script run from that parent, ``~/avhear`` cloned and ``python script.py`` in ``~``): the clone's folder is named
like the package and shadows it. Without this file ``import avhear`` gave an empty namespace package
(``module 'avhear' has no attribute 'results'``); with it, the import gives the real package, whose files are in
``avhear/`` below.
"""
from pathlib import Path as _Path

__path__ = [str(_Path(__file__).resolve().parent / "avhear")]
_inner = _Path(__path__[0]) / "__init__.py"
exec(compile(_inner.read_text(encoding="utf-8"), str(_inner), "exec"))  # noqa: S102 - the package's own code
