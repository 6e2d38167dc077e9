// servokit generate chain --masses N [--mass m] [--stiffness k] [--damping d] [--closed]
//                         [--input-mass i] [--output-mass j | --output-weights W]
//                         --out DIR [--name NAME]
// servokit generate beam  --elements N [--length L] [--hub-inertia J] [--mass-per-length r]
//                         [--bending-stiffness EI] [--damping-factor b] --out DIR [--name NAME]
//
// Writes a large linear model (modeling/linear_model.h) into DIR, made if missing, and prints the
// path of its YAML file as one line, so that `servokit analyze "$(servokit generate ...)"` works.
#include <memory>
#include <optional>
#include <ostream>
#include <string>

#include "application/commands.h"
#include "application/exit_codes.h"
#include "servokit/servokit.h"

namespace servokit {
namespace {

struct GenerateArguments {
  api::ChainModel chain;
  api::BeamModel beam;
  std::string output_weights = std::string(ToString(api::ChainModel().output_weights));
  std::string out;   // the output directory
  std::string name;  // empty: chain_N or beam_N
};

// A generator's options are its flags, spelt with '-' for '_' (--mass-per-length for
// BeamOptions::mass_per_length); an option error from the generator names the flag too.
int RunGenerate(const CLI::App& chain, const GenerateArguments& arguments, std::ostream& out) {
  api::ChainModel chain_model = arguments.chain;
  if (chain.parsed()) {
    const std::optional<ChainOutputWeights> weights =
        ChainOutputWeightsFromString(arguments.output_weights);
    if (!weights) {
      throw UsageError("--output-weights " + arguments.output_weights +
                       ": expected mass, linear or uniform");
    }
    chain_model.output_weights = *weights;
  }
  try {
    // Checked before the directory is made: a bad option leaves nothing behind.
    if (chain.parsed()) {
      chain_model.Validate();
    } else {
      arguments.beam.Validate();
    }
    MakeOutputDirectory(arguments.out);
    out << (chain.parsed() ? api::Generate(chain_model, arguments.out, arguments.name)
                           : api::Generate(arguments.beam, arguments.out, arguments.name))
        << "\n";
  } catch (const OptionError& error) {
    std::string flag = error.field();
    for (char& c : flag) {
      if (c == '_') c = '-';
    }
    throw UsageError(std::string(error.what()) + " (--" + flag + ")");
  }
  return static_cast<int>(ExitCode::kSuccess);
}

void AddOutputOptions(CLI::App& command, GenerateArguments& arguments, const std::string& stem) {
  command.add_option("--out", arguments.out, "Output directory (made if missing)")->required();
  command.add_option(
      "--name", arguments.name,
      "Model name and file stem: NAME.yaml, NAME.M.mtx, ... (default: " + stem + "_N)");
}

}  // namespace

Command AddGenerateCommand(CLI::App& app) {
  auto arguments = std::make_shared<GenerateArguments>();
  CLI::App* generate = app.add_subcommand(
      "generate", "Write a large linear model (YAML + Matrix Market files): a chain or a beam");
  generate->require_subcommand(1);
  generate->footer(
      "Prints the path of the model file it wrote.\n"
      "Examples:\n  servokit generate chain --masses 100000 --out big\n"
      "  servokit generate chain --masses 100000 --output-weights linear --out big\n"
      "  servokit generate beam --elements 1000 --hub-inertia 0.5 --out big");

  CLI::App* chain = generate->add_subcommand(
      "chain", "N masses between springs and dampers, fixed to the ground at one end");
  api::ChainModel& chain_options = arguments->chain;
  chain->add_option("--masses", chain_options.masses, "Number of masses N")->required();
  chain->add_option("--mass", chain_options.mass, "Each mass m, kg")->capture_default_str();
  chain->add_option("--stiffness", chain_options.stiffness, "Each spring k, N/m")
      ->capture_default_str();
  chain->add_option("--damping", chain_options.damping, "Each damper d, N s/m")
      ->capture_default_str();
  chain->add_option("--input-mass", chain_options.input_mass, "Mass the force acts on, 1..N")
      ->capture_default_str();
  chain->add_option("--output-mass", chain_options.output_mass, "Mass whose position is y, 1..N")
      ->capture_default_str();
  chain
      ->add_option("--output-weights", arguments->output_weights,
                   "The output y: mass (the position of --output-mass), linear (sum of (i/N) q_i "
                   "over every mass) or uniform (the mean position, sum of q_i / N); linear and "
                   "uniform mix all N coordinates (a dense row of C)")
      ->capture_default_str();
  chain->add_flag("--closed", chain_options.closed,
                  "Close the chain into a ring: mass N joined rigidly back to mass 1 (q_N = q_1, "
                  "a loop constraint); written as ring_N");
  AddOutputOptions(*chain, *arguments, "chain");

  CLI::App* beam = generate->add_subcommand(
      "beam", "A flexible link (Euler-Bernoulli, Hermite elements) on a hub driven by a torque");
  api::BeamModel& beam_options = arguments->beam;
  beam->add_option("--elements", beam_options.elements, "Number of elements N")->required();
  beam->add_option("--length", beam_options.length, "Link length L, m")->capture_default_str();
  beam->add_option("--hub-inertia", beam_options.hub_inertia, "Hub inertia J, kg m^2")
      ->capture_default_str();
  beam->add_option("--mass-per-length", beam_options.mass_per_length, "rho_a, kg/m")
      ->capture_default_str();
  beam->add_option("--bending-stiffness", beam_options.bending_stiffness, "EI, N m^2")
      ->capture_default_str();
  beam->add_option("--damping-factor", beam_options.damping_factor,
                   "beta in D = beta K (stiffness-proportional damping), s")
      ->capture_default_str();
  AddOutputOptions(*beam, *arguments, "beam");

  return {generate, [arguments, chain](std::ostream& out, std::ostream&) {
            return RunGenerate(*chain, *arguments, out);
          }};
}

}  // namespace servokit
