# Two commands set up everything on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip --disable-pip-version-check
FORMATS_VENV := .venv-formats
FORMATS_PY := $(FORMATS_VENV)/bin/python
FORMATS_PIP := $(FORMATS_PY) -m pip --disable-pip-version-check
APT_PACKAGES := xvfb libxcb-icccm4 libxcb-keysyms1

.PHONY: demo test test-fast wheel test-wheel fuzz bench-hostile file-cases bench bench-speed bench-scale bench-widget bench-metrics bench-window bench-cold formats-table study gallery screenshot install install-test system-packages clean

demo: $(VENV)/.installed
	$(VENV)/bin/napari-labyrinth demo -o demo-output --overwrite

# Every test, on every core (pytest-xdist: one process per core, tests handed out as
# workers free up). Lanes by marker: qt (a viewer under Xvfb), subprocess, slow.
test: $(VENV)/.installed-test system-packages
	$(PY) -m pytest -n auto --dist worksteal

# The lanes that need no display and start no process: what a change to core/ re-runs.
test-fast: $(VENV)/.installed-test
	$(PY) -m pytest -n auto --dist worksteal -m "not qt and not subprocess and not slow"

# The hostile-input property with 20,000 random examples (make test runs 2,000).
FUZZ_EXAMPLES ?= 20000
fuzz: $(VENV)/.installed-test
	HOSTILE_EXAMPLES=$(FUZZ_EXAMPLES) HOSTILE_SEED=random $(PY) -m pytest tests/test_hostile_properties.py -q -p no:cacheprovider

# The file cases: colour, axes and pixel sizes detected and kept, provenance, reproduce.
file-cases: $(VENV)/.installed-test
	$(PY) benchmarks/file_cases.py

# Hostile cases by class, make fuzz's count and time, peak RSS on a declared-huge file, the
# time to fail on a scheduler that never answers.
bench-hostile: $(VENV)/.installed-test
	$(PY) benchmarks/measure_hostile.py

bench: $(VENV)/.installed
	$(PY) benchmarks/bench_kernel.py
	$(PY) benchmarks/bench_parallel.py

# The formats of microscopes (the [formats] extra, through bioio): their tests, then a table of
# what is read from files written as other programs write them (CZI by pylibCZIrw, OME-TIFF by
# bioio, OME-Zarr by ome-zarr) and kept in OME-TIFF and OME-Zarr outputs, napari-ome-zarr
# opening the latter. In a venv of its own, .venv-formats: make test keeps its packages.
formats-table: $(FORMATS_VENV)/.installed
	$(FORMATS_PY) -m pytest -q -p no:cacheprovider tests/io/test_io_bioio.py \
		tests/cli/test_cli_bioio.py tests/io/test_io_kept.py
	$(FORMATS_PY) benchmarks/formats_table.py

# One plane, fast: C reference vs kernel vs labyrinth() (2048², 1 and 4 passes; 1 pass on 17
# other images), then the exact-order parallel pass (2048² and 8192², a loaded core, tile
# sizes, a model for 8/16 cores).
bench-speed: $(VENV)/.installed
	$(PY) benchmarks/bench_kernel.py --no-start-up --images
	$(PY) benchmarks/bench_parallel.py --sections exact loaded tiles model

bench-scale: $(VENV)/.installed-test
	$(PY) benchmarks/bench_scale.py --planes 200

# metrics.describe against the previous implementation (512² and 2048²; --sizes 4096 adds minutes).
bench-metrics: $(VENV)/.installed-test
	$(PY) benchmarks/bench_metrics.py --sizes 512 2048

# The widget in a real viewer under Xvfb: preview latency, stack time, cancel, event-loop gaps.
bench-widget: $(VENV)/.installed-test system-packages
	xvfb-run -a $(PY) benchmarks/bench_widget.py

# find_window: its probe's window against the full sweep's on the study images, and its time.
bench-window: $(VENV)/.installed
	$(PY) benchmarks/bench_window.py

# The study behind the presets (docs/study/) and the paper's figures (docs/gallery/).
study: $(VENV)/.installed
	$(PY) benchmarks/study.py

# The site: guide pages, the API reference and the gallery, whose examples run at build time
# (docs/examples/); warnings are errors. Its first page: docs/_build/html/index.html.
.PHONY: docs
docs: $(VENV)/.installed-docs
	$(PY) -m sphinx -W --keep-going -b html docs docs/_build/html

# The gallery's pictures that the README and docs/study show, as make docs drew them.
GALLERY_IMAGES := portrait_001:fig1-portrait thresholds_001:fig3-thresholds \
	passes_001:fig4-passes passes_002:fig4-edge-score branches_001:fig5-branches \
	liquid_crystals_001:liquid-crystals
gallery: docs
	@for pair in $(GALLERY_IMAGES); do \
	  cp docs/auto_examples/images/sphx_glr_plot_$${pair%%:*}.png docs/gallery/$${pair#*:}.png \
	    && echo docs/gallery/$${pair#*:}.png || exit 1; \
	done

screenshot: $(VENV)/.installed-test system-packages
	xvfb-run -a $(PY) docs/make_screenshot.py

install: $(VENV)/.installed
install-test: $(VENV)/.installed-test

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --upgrade pip

$(VENV)/.installed: $(PY) pyproject.toml
	$(PIP) install -e .
	touch $@

# The tests build the docs site too (tests/test_docs_build.py): the docs extra comes along.
$(VENV)/.installed-test: $(VENV)/.installed pyproject.toml
	$(PIP) install -e ".[test,docs]"
	touch $@

$(VENV)/.installed-docs: $(VENV)/.installed pyproject.toml
	$(PIP) install -e ".[docs]"
	touch $@

$(FORMATS_PY):
	$(PYTHON) -m venv $(FORMATS_VENV)
	$(FORMATS_PIP) install --upgrade pip

# pylibCZIrw writes the CZI files, napari-ome-zarr (and napari, without Qt) opens the OME-Zarr
# outputs; the dask extra reads lazily and writes zarr outputs with their pyramids (ome-zarr).
$(FORMATS_VENV)/.installed: $(FORMATS_PY) pyproject.toml
	$(FORMATS_PIP) install -e ".[formats,dask]" pylibCZIrw napari-ome-zarr pytest
	touch $@

# Headless Qt needs an X server (Xvfb) and two xcb libraries beyond the base image.
system-packages:
	@missing=""; for p in $(APT_PACKAGES); do \
	  dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "installing$$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing; \
	  else \
	    echo "missing system packages:$$missing (run: sudo apt-get install$$missing)"; exit 1; \
	  fi; \
	fi

clean:
	rm -rf $(VENV) $(FORMATS_VENV) demo-output build dist .pytest_cache .hypothesis

# Cold start: first call against second, each row in a new process with an empty numba
# cache (API, CLI, the widget opened from the Plugins menu); BEFORE=f22d86f adds that commit.
bench-cold: $(VENV)/.installed-test system-packages
	xvfb-run -a $(PY) benchmarks/bench_cold_start.py $(if $(BEFORE),--before $(BEFORE))

# The distributions in dist/: the sdist and the pure wheel (py3-none-any: numba compiles the
# kernels on the user's machine), then this machine's platform wheel, which carries them
# compiled for its CPU target (hatch_build.py runs every first call a user can make: minutes).
wheel: $(VENV)/.installed-test
	rm -rf dist build/kernels
	PATH="$(CURDIR)/$(VENV)/bin:$$PATH" $(PY) -m build --installer uv --outdir dist .
	HATCH_BUILD_HOOK_ENABLE_CUSTOM=true $(PY) -m build --wheel --no-isolation --outdir dist .
	@ls -l dist

# The whole suite run from the platform wheel in a fresh venv with an empty numba cache, as
# a user's machine meets it; its summary counts the kernels numba compiled (0: the wheel
# carries every one the tests call). Then the first calls checked against the JIT. The venv is
# byte-compiled, as pip installs (uv alone leaves it to the first imports).
WHEEL_VENV := build/wheel-venv
test-wheel: wheel system-packages
	rm -rf $(WHEEL_VENV) build/wheel-numba-cache
	$(VENV)/bin/uv venv -q --seed --python $(PY) $(WHEEL_VENV)
	$(VENV)/bin/uv pip install -q --compile-bytecode --python $(WHEEL_VENV)/bin/python \
		"$$(ls dist/napari_labyrinth-*-cp*.whl)[test,docs]"
	cd build && NUMBA_CACHE_DIR=$(CURDIR)/build/wheel-numba-cache \
		$(CURDIR)/$(WHEEL_VENV)/bin/python -m pytest -n auto --dist worksteal \
		-p no:cacheprovider --rootdir $(CURDIR) -c $(CURDIR)/pyproject.toml $(CURDIR)/tests
	$(WHEEL_VENV)/bin/python benchmarks/check_shipped_kernels.py

# The built wheel installed as users install it (a fresh venv they cannot write to), its
# numba cache in their cache directory, and no cache at all (1-2 min): not part of make test.
.PHONY: test-install
test-install: $(VENV)/.installed-test
	NAPARI_LABYRINTH_INSTALL_TESTS=1 $(PY) -m pytest tests/test_install_wheel.py -v \
		-p no:cacheprovider

# The environments the project claims, from the built wheel: napari 0.5 / 0.6 / latest with
# PyQt5, PyQt6 and PySide6, the oldest napari with numpy 1.26 (noxfile.py), then the install
# test. Not part of make test. One session: make test-matrix NOX_ARGS="-s napari-latest-pyside6".
NOX_ARGS ?=
# MATRIX_REF=HEAD tests that commit, not the working tree (others may be editing it).
MATRIX_REF ?=
# What the xcb platform plugins of Qt 5 and Qt 6 link (ldd of PyQt5, PyQt6 and PySide6);
# the base image lacks only PyQt5's libxcb-xinerama0 beyond APT_PACKAGES.
QT_APT_PACKAGES := libxcb-xinerama0 libxcb-cursor0 libxcb-image0 libxcb-randr0 \
	libxcb-render-util0 libxcb-shape0 libxcb-sync1 libxcb-xfixes0 libxcb-xkb1 libx11-xcb1 \
	libxcb-dri3-0 libxkbcommon-x11-0 libfontconfig1 libdbus-1-3 libglib2.0-0 libgl1 libegl1
MATRIX_SUMMARY := build/nox/summary

.PHONY: test-matrix
test-matrix: APT_PACKAGES += $(QT_APT_PACKAGES)
test-matrix: $(VENV)/.installed-test system-packages
	$(PIP) install -q "nox>=2025.2.9" "uv>=0.5"
	@rm -rf $(MATRIX_SUMMARY); mkdir -p $(MATRIX_SUMMARY); start=$$(date +%s); status=0; \
	NAPARI_LABYRINTH_MATRIX_REF=$(MATRIX_REF) $(VENV)/bin/nox $(NOX_ARGS) || status=1; \
	if [ -z "$(NOX_ARGS)" ]; then t=$$(date +%s); \
	  NAPARI_LABYRINTH_INSTALL_TESTS=1 $(PY) -m pytest tests/test_install_wheel.py -q \
	    -p no:cacheprovider && r=passed || { r=failed; status=1; }; \
	  echo "install-test: $$r ($$(( $$(date +%s) - t )) s)" > $(MATRIX_SUMMARY)/zz-install.txt; \
	fi; \
	echo; echo "== test matrix ($$(( $$(date +%s) - start )) s)"; \
	for f in $(MATRIX_SUMMARY)/*.txt; do case $$f in *.failed.txt) ;; *) cat $$f;; esac; done; \
	cat $(MATRIX_SUMMARY)/*.failed.txt 2>/dev/null | sed 's/^/  FAILED /'; \
	exit $$status
