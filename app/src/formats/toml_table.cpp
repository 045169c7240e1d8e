#include "gyrotc/app/formats/toml_table.hpp"

#include <cstdio>

namespace gyrotc::app {

std::string format_toml_number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

const toml::table* toml_section(const toml::table& root, const std::string& name, const std::string& source) {
  const toml::node* node = root.get(name);
  if (node == nullptr) return nullptr;
  if (!node->is_table()) {
    throw InputError(source + ":" + std::to_string(node->source().begin.line) + ": " + name + ": expected a table");
  }
  return node->as_table();
}

}  // namespace gyrotc::app
