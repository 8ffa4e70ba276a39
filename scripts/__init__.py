"""The demos and build scripts: `make demo` runs `python -m scripts.demo` from the checkout."""
