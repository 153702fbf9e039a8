// quadid's front door: every public header of the library, for programs that use
// quadid (tests/consumer/ is one). Modules inside the library include only what
// they use (scripts/check_modules.py refuses this header there), so the module
// graph in docs/architecture.md stays true.
#pragma once

#include "quadid/batch.hpp"
#include "quadid/checks.hpp"
#include "quadid/control.hpp"
#include "quadid/core.hpp"
#include "quadid/design.hpp"
#include "quadid/estimation.hpp"
#include "quadid/export.hpp"
#include "quadid/identification.hpp"
#include "quadid/io.hpp"
#include "quadid/logs.hpp"
#include "quadid/model.hpp"
#include "quadid/montecarlo.hpp"
#include "quadid/pipeline.hpp"
#include "quadid/precision.hpp"
#include "quadid/regression.hpp"
#include "quadid/report.hpp"
#include "quadid/reproduce.hpp"
#include "quadid/signal.hpp"
#include "quadid/simulation.hpp"
#include "quadid/trajectory.hpp"
#include "quadid/validation.hpp"
#include "quadid/vehicle.hpp"
#include "quadid/core/parallel.hpp"
#include "quadid/estimation/qr_least_squares.hpp"
#include "quadid/identification/extended.hpp"
#include "quadid/identification/timing.hpp"
#include "quadid/model/dual.hpp"
#include "quadid/model/regressor.hpp"
