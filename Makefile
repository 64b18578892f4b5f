# Two commands on a fresh machine:
#   make demo   install everything, then denoise the embedded sample (fandisk with synthetic stripes)
#   make test   install everything, then run the test suite
PYTHON ?= python3
PIP ?= $(PYTHON) -m pip

.PHONY: setup demo test bench docs

setup:
	@# open3d's wheel links against libusb-1.0 (a system library, not a wheel)
	@if ! ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; then \
		echo "installing libusb-1.0-0 (needed by open3d)"; \
		SUDO=$$( [ "$$(id -u)" -eq 0 ] || echo sudo ); \
		$$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq libusb-1.0-0; \
	fi
	$(PIP) install -q -e '.[test]'

demo: setup
	$(PYTHON) -m skelfilter.demo --out demo-output

test: setup
	$(PYTHON) -m pytest -q -p no:cacheprovider tests

bench: setup
	$(PYTHON) benchmarks/bench_pipeline.py

docs: setup
	$(PYTHON) -m skelfilter.cli filters --markdown > docs/filters.md
