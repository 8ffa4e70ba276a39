"""The benchmarks: `make bench` runs each as `python -m bench.NAME` from the checkout."""
