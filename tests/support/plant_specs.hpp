// Small builders of plant specs (physics/plant.hpp) shared by the plant tests.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "physics/plant.hpp"

namespace cansim::test {

// A block input naming an input or a block output.
inline physics::PlantSignal ref(const std::string& name) { return physics::PlantSignal{name, 0.0, ""}; }

// An input that is a function of time (today's process terms).
inline physics::PlantInputSpec time_input(const std::string& name, std::vector<physics::TermSpec> terms) {
  physics::PlantInputSpec in;
  in.name = name;
  in.source = physics::PlantInputSpec::Source::kTime;
  in.terms = std::move(terms);
  return in;
}

}  // namespace cansim::test
