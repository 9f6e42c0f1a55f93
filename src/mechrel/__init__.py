"""mechrel: dynamic response errors and accuracy reliability of planar mechanisms with
clearance joints (dry, lubricated and transition), with an uncertainty-quantification layer."""

__all__ = ["__version__"]


def __getattr__(name: str):
    # the version is read from the installed metadata when first asked for: importlib.metadata
    # is slow to import, and ``mechrel`` starts by importing this package before anything else
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("mechrel")
        except PackageNotFoundError:  # pragma: no cover - running from a source tree
            value = "0.0.0+unknown"
        globals()["__version__"] = value
        return value
    raise AttributeError(f"module 'mechrel' has no attribute {name!r}")
