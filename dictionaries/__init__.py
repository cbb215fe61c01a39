"""Dictionaries shipped with sparseedm (see README.md here)."""
