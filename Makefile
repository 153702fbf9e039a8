# The README's commands. `make build` leaves the optimized program at build/quadid.
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
OUT  ?= reproduction

.PHONY: deps build python test reproduce bench asan clean
deps:
	scripts/install-deps.sh
build:
	cmake --preset release -DQUADID_BUILD_BENCH=OFF
	cmake --build build -j $(JOBS) --target quadid
# The Python module into build/python (PYTHONPATH=build/python /usr/bin/python3 -c 'import quadid').
python:
	cmake --preset release -DQUADID_BUILD_BENCH=OFF
	cmake --build build -j $(JOBS) --target quadid_python
# ctest runs the GoogleTest suite and the Python module's pytest suite (one CTest test, /usr/bin/python3).
test:
	cmake --preset release -DQUADID_BUILD_BENCH=OFF -DQUADID_WERROR=ON
	cmake --build build -j $(JOBS)
	cd build && ctest --output-on-failure -j $(JOBS)
reproduce: build
	build/quadid reproduce --out $(OUT)
bench:
	cmake --preset release -DQUADID_BUILD_BENCH=ON
	cmake --build build -j $(JOBS)
	for b in build/bench/bench_*; do $$b; done
asan:
	cmake --preset asan
	cmake --build build-asan -j $(JOBS)
	cd build-asan && ctest --output-on-failure -j $(JOBS)
clean:
	rm -rf build build-debug build-asan
