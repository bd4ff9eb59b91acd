"""Readers and writers of hair and mesh files, one module per format."""
