// api::Generate: large linear models written as `servokit generate chain|beam` writes them.
#include <filesystem>
#include <optional>

#include "base/errors.h"
#include "modeling/model_generators.h"
#include "servokit/servokit.h"

namespace servokit::api {
namespace {

std::string Write(LinearModelFiles files, const std::string& directory, const std::string& name) {
  if (!name.empty()) files.name = name;
  std::error_code error;
  std::filesystem::create_directories(directory, error);
  if (error) throw Error(directory + ": cannot create the directory: " + error.message());
  return WriteLinearModel(files, directory);
}

ChainOptions ToChainOptions(const ChainModel& chain) {
  ChainOptions options;
  options.masses = chain.masses;
  options.mass = chain.mass;
  options.stiffness = chain.stiffness;
  options.damping = chain.damping;
  options.input_mass = chain.input_mass;
  options.output_mass = chain.output_mass;
  options.output_weights = chain.output_weights;
  options.closed = chain.closed;
  return options;
}

BeamOptions ToBeamOptions(const BeamModel& beam) {
  BeamOptions options;
  options.elements = beam.elements;
  options.length = beam.length;
  options.hub_inertia = beam.hub_inertia;
  options.mass_per_length = beam.mass_per_length;
  options.bending_stiffness = beam.bending_stiffness;
  options.damping_factor = beam.damping_factor;
  return options;
}

}  // namespace

// Each built once, every field given (see DefaultAnalyzeOptions).
const ChainModel& DefaultChainModel() {
  static const ChainOptions options;
  static const ChainModel defaults{.masses = options.masses,
                                   .mass = options.mass,
                                   .stiffness = options.stiffness,
                                   .damping = options.damping,
                                   .input_mass = options.input_mass,
                                   .output_mass = options.output_mass,
                                   .output_weights = options.output_weights,
                                   .closed = options.closed};
  return defaults;
}

const BeamModel& DefaultBeamModel() {
  static const BeamOptions options;
  static const BeamModel defaults{.elements = options.elements,
                                  .length = options.length,
                                  .hub_inertia = options.hub_inertia,
                                  .mass_per_length = options.mass_per_length,
                                  .bending_stiffness = options.bending_stiffness,
                                  .damping_factor = options.damping_factor};
  return defaults;
}

void ChainModel::Validate() const { ToChainOptions(*this).Validate(); }
void BeamModel::Validate() const { ToBeamOptions(*this).Validate(); }

std::string Generate(const ChainModel& chain,
                     const std::string& directory,
                     const std::string& name) {
  return Write(GenerateChain(ToChainOptions(chain)), directory, name);
}

std::string Generate(const BeamModel& beam, const std::string& directory, const std::string& name) {
  return Write(GenerateBeam(ToBeamOptions(beam)), directory, name);
}

}  // namespace servokit::api
