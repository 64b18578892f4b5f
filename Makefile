# Two commands on a fresh machine:
#   make demo   install everything, then denoise the embedded sample (fandisk with synthetic stripes)
#   make test   install everything, then run the test suite
PYTHON ?= python3
PIP ?= $(PYTHON) -m pip

.PHONY: setup demo test lint bench docs

# System libraries the wheels need: libusb-1.0-0 (open3d links against it), libosmesa6 (pyvista/VTK
# draw the comparison's pictures off-screen on the CPU); chromium (the test that opens the report).
SYSTEM_PACKAGES = libusb-1.0-0 libosmesa6 chromium

setup:
	@missing=$$(for p in $(SYSTEM_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then \
		echo "installing system packages:" $$missing; \
		SUDO=$$( [ "$$(id -u)" -eq 0 ] || echo sudo ); \
		$$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq $$missing; \
	fi
	$(PIP) install -q -e '.[test]'
	$(PYTHON) -m skelfilter.cli.warm_up

demo: setup
	$(PYTHON) -m skelfilter.demo --out demo-output

test: setup
	$(PYTHON) -m pytest -q -p no:cacheprovider tests

lint: setup
	$(PYTHON) -m ruff check .

bench: setup
	$(PYTHON) benchmarks/bench_pipeline.py

docs: setup
	$(PYTHON) -m skelfilter.cli filters --markdown > docs/filters.md
