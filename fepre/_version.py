"""fepre's version, from the installed package's metadata (``fepre.__version__``)."""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("fepre")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
