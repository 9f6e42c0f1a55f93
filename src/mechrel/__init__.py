"""mechrel: dynamic response errors and accuracy reliability of planar mechanisms with
clearance joints (dry, lubricated and transition), with an uncertainty-quantification layer."""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("mechrel")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
