#!/usr/bin/env bash
# Installs what quadid needs to build and test on Debian 12. Idempotent.
set -euo pipefail
PKGS=(g++ cmake make libeigen3-dev libnlopt-cxx-dev libnlopt-dev libcli11-dev nlohmann-json3-dev
      libfmt-dev libgtest-dev libgmock-dev libbenchmark-dev libtomlplusplus-dev
      liburdfdom-dev libsdformat-dev  # tests read the exported URDF and SDF back with their parsers (quadid model)
      clang libclang-rt-dev
      pybind11-dev python3-dev python3-numpy python3-pytest python3-distributed
      chromium)  # the report test renders pages in a real browser (ReportBrowser)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# The build installs uPlot from npm for the reports' interactive charts (cmake/Uplot.cmake).
# Machines that carry NodeSource's nodejs already have npm, and that nodejs conflicts with
# Debian's npm package ("held broken packages"), so Debian's npm only where no npm runs.
command -v npm >/dev/null 2>&1 || missing+=(npm)
if [ ${#missing[@]} -eq 0 ]; then echo "install-deps: all packages present"; exit 0; fi
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
