# Two commands on a fresh machine:
#   make demo   install skelfilter alone, then denoise the embedded sample (fandisk with synthetic stripes)
#   make test   install everything, then run the test suite
PYTHON ?= python3
PIP ?= $(PYTHON) -m pip

.PHONY: setup setup-demo demo test lint bench docs

# System libraries the extras' wheels need: libusb-1.0-0 (open3d, the point clouds' extra, links against
# it), libosmesa6 (pyvista/VTK draw the comparison's pictures off-screen on the CPU) and chromium (the
# test that opens the report in a browser). The core install, and so the demo, needs none.
SYSTEM_PACKAGES = libusb-1.0-0 libosmesa6 chromium

# $(call system_packages,LIST): apt-get install those of LIST that are missing.
define system_packages
	@missing=$$(for p in $(1); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then \
		echo "installing system packages:" $$missing; \
		SUDO=$$( [ "$$(id -u)" -eq 0 ] || echo sudo ); \
		$$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq $$missing; \
	fi
endef

setup:
	$(call system_packages,$(SYSTEM_PACKAGES))
	$(PIP) install -q -e '.[test]'
	$(PYTHON) -m skelfilter.cli.warm_up

setup-demo:
	$(PIP) install -q -e .
	$(PYTHON) -m skelfilter.cli.warm_up

demo: setup-demo
	$(PYTHON) -m skelfilter.demo --out demo-output

test: setup
	$(PYTHON) -m pytest -q -p no:cacheprovider tests
	$(PYTHON) -m pytest -q -p no:cacheprovider --doctest-modules skelfilter

lint: setup
	$(PYTHON) -m ruff check .

bench: setup
	$(PYTHON) -m benchmarks.bench_pipeline

docs: setup
	$(PYTHON) -m skelfilter.cli filters --markdown > docs/filters.md
