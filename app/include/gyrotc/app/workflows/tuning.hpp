#pragma once

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/algorithms/tune/controller_design.hpp"
#include "gyrotc/algorithms/tune/experiment.hpp"
#include "gyrotc/algorithms/tune/thermal_identify.hpp"
#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"

// What `gyrotc tune` does behind its command line (issue 23): read the
// unit's identification record, identify its thermal model, design its
// controller, and put both into a controller file and a report. The robustness
// suite (tools/tune_suite) and the benchmark call the same functions.
namespace gyrotc::app {

// The loop tune designs: the model-based loop (control/observer_loop.hpp on
// the identified housing, tune/identified_housing.hpp) or the seed's PID
// structure with tuned gains (tune/controller_design.hpp).
enum class TuneLoop { observer, pid };

struct TuneInput {
  tune::TuneRecord record;
  double setpoint_c = 55.0;  // the record's setpoint_c column when it has one
  std::string source;        // the file, for messages
  double experiment_scale = 1.0;  // the record's experiment was ExperimentPlan::scaled by this
  TuneLoop loop = TuneLoop::pid;
};

// Reads time_s, sensor_c, tec_a and, when present, ambient_c ("nan" before
// the first ambient reading) and setpoint_c; nothing else (a simulated
// record's casing_c, die_c and tec_v are the plant's truth, which a board
// does not have). InputError naming the file: a missing column (and what
// tune needs), a bad cell (its line).
TuneInput read_tune_record(const std::string& path);

struct TuneResult {
  tune::ThermalFit fit;
  tune::DesignSpec spec;
  tune::ControllerDesign design;
  bool pid_designed = false;  // design holds the PID's (TuneLoop::observer: it may have failed)
  std::shared_ptr<const control::ObserverLoopDesign> observer;  // TuneLoop::observer
  ControllerFile controller;
  std::vector<std::string> warnings;
  double identify_s = 0.0;
  double design_s = 0.0;
};

// InputError naming the source when the record cannot be tuned from (what is
// missing: excitation, response, a continuous record, ...), or the loop
// asked for cannot be designed. With TuneLoop::observer the PID is designed
// as well, for comparison, and a PID design that fails is a warning.
TuneResult tune_from_record(const TuneInput& input);

// The chamber of `gyrotc simulate --profile tune`: room_c for as long as the
// experiment can take, or, with ambient_step_c != 0, room_c until
// ambient_step_at_s(plan), then a ramp at 1 C/min (data/README.md's chamber
// rate) to room_c + ambient_step_c, held to the end: the unit is then held
// near the setpoint (the relay or the PRBS), and the record shows how a
// change of the room reaches the sensor (tune's sensor_ambient_share).
model::ChamberProfile tune_experiment_room(double room_c, const tune::ExperimentPlan& plan = {},
                                           double ambient_step_c = 0.0);

// When the chamber's step starts: the longest the approach may take, so that
// the unit is held near the setpoint whatever its warm-up.
double ambient_step_at_s(const tune::ExperimentPlan& plan);

// The identification experiment on the simulated board in lockstep, as
// `gyrotc simulate --profile tune` runs it: every node and the room at
// room_c, the TEC limited to the plant's current limit (or to
// configured_limit_a when it is > 0: a board configured below or above what
// its stage delivers), an ambient DS18B20, the seed's reference calibration,
// the chamber stepping by ambient_step_c (tune_experiment_room); ends with
// the experiment. write_board_record_csv(rows) is the record `gyrotc tune`
// reads.
SimulationResult simulate_tune_experiment(const model::PlantParams& plant, double room_c, double sample_rate_hz,
                                          const tune::ExperimentPlan& plan = {}, double configured_limit_a = 0.0,
                                          double ambient_step_c = 0.0);

// The plant's physical minimum warm-up (issue 23): every node at from_c, the
// TEC commanded at the stage's current limit (the plant clips it at its
// rails), until the casing reaches target_c; -1 when it does not within 4 h.
double plant_minimum_warm_up_s(const model::PlantParams& plant, double from_c, double target_c);

// The [identified] and [design] tables written below the controller.
std::string tune_informational_toml(const TuneResult& result, const std::string& source);
nlohmann::json tune_json(const TuneResult& result);

}  // namespace gyrotc::app
