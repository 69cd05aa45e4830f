"""The version of gearsym (one place; the package root and the build keys read it)."""

__version__ = "0.1.0"
