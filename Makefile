# sgpipe — two commands do all set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
SGPIPE := $(VENV)/bin/sgpipe
STAMP  := $(VENV)/.sgpipe-installed
BENCH_STAMP := $(VENV)/.sgpipe-bench-installed
OUT    ?= out

VALIDATE_STAMP := $(VENV)/.sgpipe-validate-installed

.PHONY: setup opencl vulkan browser demo test fuzz bench validate figures samples doctor clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test,dask]'
	touch $(STAMP)

# the benchmarks' baselines (scikit-learn, ...): the `bench` extra, on top of the base install
$(BENCH_STAMP): $(STAMP)
	$(PY) -m pip install -q -e '.[test,dask,bench]'
	touch $(BENCH_STAMP)

# Mitsuba 3, the independent renderer `make validate` checks the reference against
$(VALIDATE_STAMP): $(STAMP)
	$(PY) -m pip install -q -e '.[test,dask,validate]'
	touch $(VALIDATE_STAMP)

setup: $(STAMP) opencl vulkan browser

# headless Chromium + chromedriver for the HTML report's browser test
browser: $(STAMP)
	@bash tools/ensure_browser.sh

opencl: $(STAMP)
	@bash tools/ensure_opencl.sh $(PY)

# Mesa's lavapipe: the CPU Vulkan device the Khronos glTF-IBL-Sampler runs on in the tests
vulkan: $(STAMP)
	@bash tools/ensure_vulkan.sh

doctor: setup
	$(SGPIPE) doctor

## the sample pipeline, end to end, on data_samples/
demo: setup
	$(SGPIPE) run configs/demo.yaml --out $(OUT)/demo
	@echo "demo outputs: $(abspath $(OUT)/demo)"

## the test suite (what CI runs)
test: setup
	$(PY) -m pytest -q -n 2 --dist loadfile

## the config loader and file readers against damaged input, longer than `make test` runs it
fuzz: setup
	SGPIPE_FUZZ_EXAMPLES=$${SGPIPE_FUZZ_EXAMPLES:-5000} $(PY) -m pytest -q tests/foundation/test_fuzz.py

## speed and memory targets, printed as ratios against baselines measured in the same run
bench: setup $(BENCH_STAMP)
	$(PY) -m benchmarks

## the Monte Carlo reference against Mitsuba 3 on scenes of its own (display PSNR, FLIP)
validate: setup $(VALIDATE_STAMP)
	@bash tools/ensure_llvm.sh
	$(PY) -m validation --out $(OUT)/validate

## the papers' experiments: Töral19 (docs/RESULTS.md), Han07 and Green06 (docs/results/), sheets,
## and the fidelity corpus (docs/results/fidelity.md)
figures: setup
	$(PY) -m sgpipe.experiments.figures --out $(OUT)/figures
	$(PY) -m sgpipe.experiments.fidelity --out $(OUT)/figures/fidelity --results docs/results/fidelity.md
	$(PY) -m sgpipe.experiments.han07 --out $(OUT)/figures/han07
	$(PY) -m sgpipe.experiments.green06 --out $(OUT)/figures/green06 --results docs/results/green06.md
	$(PY) -m sgpipe.experiments.wang09 --out $(OUT)/figures/wang09 --results docs/results/wang09.md
	$(PY) -m sgpipe.experiments.toral19 --out $(OUT)/figures/toral19 --results docs/results/toral19.md
	$(PY) -m sgpipe.experiments.green06_ladder --out $(OUT)/figures/green06_ladder --results docs/results/green06_ladder.md
	$(PY) -m sgpipe.experiments.green06_indirect --out $(OUT)/figures/green06_indirect --results docs/results/green06_indirect.md
	$(PY) -m sgpipe.experiments.han07_ladder --out $(OUT)/figures/han07_ladder --results docs/results/han07_ladder.md
	$(PY) -m sgpipe.experiments.gltf_textures --out $(OUT)/figures/gltf_textures --results docs/results/gltf_textures.md

## regenerate data_samples/ (deterministic)
samples: $(STAMP)
	$(PY) tools/make_data_samples.py --out data_samples

clean:
	rm -rf $(OUT) .pytest_cache
