#pragma once

#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>
#include <utility>

#include <toml++/toml.h>

#include "gyrotc/app/support/errors.hpp"

// One table of a TOML file the daemon or a command reads (the configuration,
// a controller file): typed, range-checked keys, unknown keys refused, and
// the file, the line and section.key in every InputError:
// "gyrotc.toml:12: control.period_s: must be within 0.01 .. 3600, got -2".
namespace gyrotc::app {

// root's table `name`, nullptr when absent; an InputError when it is not a table.
const toml::table* toml_section(const toml::table& root, const std::string& name, const std::string& source);

// A key's range without an upper end: TomlTable::number(key, fallback, min, kUnbounded).
inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

// A number as the messages show it (%g).
std::string format_toml_number(double v);

class TomlTable {
 public:
  TomlTable(const toml::table* table, std::string name, const std::string& source,
            std::initializer_list<std::string_view> allowed)
      : table_(table), name_(std::move(name)), source_(source) {
    refuse_unknown_keys([&](std::string_view key) { return std::find(allowed.begin(), allowed.end(), key) != allowed.end(); });
  }
  // allowed(key): whether the table may hold key (e.g. whether a table of
  // key descriptions names it).
  template <typename Allowed>
  TomlTable(const toml::table* table, std::string name, const std::string& source, Allowed allowed)
      : table_(table), name_(std::move(name)), source_(source) {
    refuse_unknown_keys(allowed);
  }

  [[noreturn]] void fail(const toml::node& node, const std::string& key, const std::string& why) const {
    throw InputError(source_ + ":" + std::to_string(node.source().begin.line) + ": " + name_ + "." + key + ": " +
                     why);
  }
  // An error about a key when present, else about the table.
  [[noreturn]] void fail_at(const std::string& key, const std::string& why) const {
    const toml::node* node = table_ != nullptr ? table_->get(key) : nullptr;
    if (node != nullptr) fail(*node, key, why);
    const int line = table_ != nullptr ? static_cast<int>(table_->source().begin.line) : 0;
    throw InputError(source_ + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + name_ + "." + key +
                     ": " + why);
  }

  const toml::node* get(const std::string& key) const { return table_ != nullptr ? table_->get(key) : nullptr; }

  double number(const std::string& key, double fallback, double min, double max) const {
    const toml::node* node = get(key);
    if (node == nullptr) return fallback;
    if (!node->is_number()) fail(*node, key, "expected a number");
    const double value = *node->value<double>();
    if (!(value >= min && value <= max)) {
      fail(*node, key, "must be within " + format_toml_number(min) + " .. " + format_toml_number(max) + ", got " +
                           format_toml_number(value));
    }
    return value;
  }

  std::int64_t integer(const std::string& key, std::int64_t fallback, std::int64_t min, std::int64_t max) const {
    const toml::node* node = get(key);
    if (node == nullptr) return fallback;
    if (!node->is_integer()) fail(*node, key, "expected an integer");
    const std::int64_t value = *node->value<std::int64_t>();
    if (value < min || value > max) {
      fail(*node, key, "must be within " + std::to_string(min) + " .. " + std::to_string(max) + ", got " +
                           std::to_string(value));
    }
    return value;
  }

  std::string string(const std::string& key, const std::string& fallback) const {
    const toml::node* node = get(key);
    if (node == nullptr) return fallback;
    if (!node->is_string()) fail(*node, key, "expected a string");
    return *node->value<std::string>();
  }

  bool boolean(const std::string& key, bool fallback) const {
    const toml::node* node = get(key);
    if (node == nullptr) return fallback;
    if (!node->is_boolean()) fail(*node, key, "expected true or false");
    return *node->value<bool>();
  }

 private:
  template <typename Allowed>
  void refuse_unknown_keys(Allowed allowed) const {
    if (table_ == nullptr) return;
    for (auto&& [key, node] : *table_) {
      if (!allowed(key.str())) fail(node, std::string(key.str()), "unknown key in [" + name_ + "]");
    }
  }
  const toml::table* table_;
  std::string name_;
  const std::string& source_;
};

}  // namespace gyrotc::app
