#include "scene/authoring_error.h"

#include <cctype>

namespace cressim::scene {
namespace {

// "Collider.shapes[0].size must be ..." -> "Collider.shapes[0].size"; "env 1 has ..." -> ""
std::string leading_field(const std::string& problem) {
  if (problem.empty() || !std::isupper(static_cast<unsigned char>(problem[0]))) return "";
  size_t n = 0;
  while (n < problem.size() && (std::isalnum(static_cast<unsigned char>(problem[n])) || problem[n] == '_' ||
                                problem[n] == '.' || problem[n] == '[' || problem[n] == ']'))
    ++n;
  while (n > 0 && problem[n - 1] == '.') --n;  // a sentence's full stop
  return problem.substr(0, n);
}

std::string message(const World& world, EntityId entity, const std::string& problem, const std::string& field) {
  const std::string source = world.source_of(entity, field);
  return (source.empty() ? "" : source + ": ") + world.describe(entity) + ": " + problem;
}

}  // namespace

AuthoringError::AuthoringError(const World& world, EntityId e, const std::string& problem, std::string f)
    : std::invalid_argument(message(world, e, problem, f.empty() ? leading_field(problem) : f)),
      entity(e),
      env(world.env_of(e)),
      field(f.empty() ? leading_field(problem) : std::move(f)),
      source(world.source_of(e, field)) {}

}  // namespace cressim::scene
