"""Tables, figures and provenance files."""

from .tables import save_figure, write_json, write_table

__all__ = ["write_table", "write_json", "save_figure"]
