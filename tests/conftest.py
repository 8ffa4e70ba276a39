"""pytest on the miniskeleton_core Python API (no Blender). `make test-python` puts the freshly
built wheel on PYTHONPATH (.build/core)."""
