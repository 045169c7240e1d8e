#include "gyrotc/app/cli/cli_main.hpp"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {

namespace {

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// The name closest to `word`, if it is close enough to be a typo of it (or
// `word` is its start), else "".
std::string closest(std::string_view word, const std::vector<std::string>& names) {
  std::string best;
  std::size_t best_distance = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const std::string& name : names) {
    if (word.size() >= 3 && name.rfind(word, 0) == 0) return name;
    const std::size_t d = edit_distance(word, name);
    if (d < best_distance) {
      best_distance = d;
      best = name;
    }
  }
  return best;
}

std::vector<CLI::App*> commands_of(CLI::App& app) {
  return app.get_subcommands([](CLI::App*) { return true; });
}

std::vector<std::string> long_names(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::Option* option : app.get_options()) {
    for (const std::string& n : option->get_lnames()) names.push_back("--" + n);
  }
  return names;
}

bool is_option_of(const CLI::App& app, const std::string& token) {
  const std::string name = token.substr(0, token.find('='));
  const std::vector<std::string> names = long_names(app);
  return std::find(names.begin(), names.end(), name) != names.end();
}

// The deepest command named on the command line (e.g. `report settle`), or
// nullptr when argv names none; `unknown` gets the first word that should
// have been a command and is not one.
CLI::App* named_command(CLI::App& cli, int argc, const char* const* argv, std::string& unknown) {
  CLI::App* current = nullptr;
  CLI::App* scope = &cli;
  for (int i = 1; i < argc; ++i) {
    const std::string token = argv[i];
    if (token.empty() || token[0] == '-') continue;
    const std::vector<CLI::App*> subs = commands_of(*scope);
    if (subs.empty()) break;  // a positional value of the command
    const auto it = std::find_if(subs.begin(), subs.end(), [&](CLI::App* s) { return s->check_name(token); });
    if (it == subs.end()) {
      if (scope->get_require_subcommand_min() > 0) unknown = token;
      break;
    }
    current = scope = *it;
  }
  return current;
}

std::string command_path(const CLI::App* command) {
  std::string path;
  for (const CLI::App* a = command; a != nullptr && a->get_parent() != nullptr; a = a->get_parent()) {
    path = a->get_name() + (path.empty() ? "" : " " + path);
  }
  return path;
}

// The first sentence of a command's description, for the short help.
std::string summary(const std::string& description) {
  std::string text;
  for (const char c : description) text += c == '\n' ? ' ' : c;
  std::size_t end = text.size();
  for (std::size_t i = 0; i + 1 < text.size(); ++i) {
    if ((text[i] == ':' || text[i] == '.') && text[i + 1] == ' ') {
      end = i;
      break;
    }
  }
  text.resize(end);
  if (!text.empty() && text.back() == '.') text.pop_back();
  return text;
}

void print_short_help(CLI::App& cli, const char* program, std::ostream& out) {
  const std::string& description = cli.get_description();
  out << description.substr(0, description.find('\n')) << "\n\nUsage: " << program << " <command> [options]\n\nCommands:\n";
  std::size_t width = 0;
  for (const CLI::App* c : commands_of(cli)) width = std::max(width, c->get_name().size());
  for (const CLI::App* c : commands_of(cli)) {
    out << "  " << c->get_name() << std::string(width + 2 - c->get_name().size(), ' ')
        << summary(c->get_description()) << "\n";
  }
  out << "\nRun '" << program << " <command> --help' for the options of a command, '" << program
      << " --help' for all.\n";
}

// Unsigned options refuse a sign: the parser would wrap "-1" to 2^64 - 1.
void refuse_signed_unsigned(CLI::App& app) {
  for (CLI::Option* option : app.get_options([](const CLI::Option*) { return true; })) {
    if (option->get_type_name().rfind("UINT", 0) == 0) {
      option->check(CLI::Validator(
          [](std::string& value) -> std::string {
            if (value.find('-') == std::string::npos) return {};
            return "must be a whole number >= 0, got " + value;
          },
          "", "unsigned"));
    }
  }
  for (CLI::App* sub : commands_of(app)) refuse_signed_unsigned(*sub);
}

std::string usage_hint(const CLI::App* command, const char* program) {
  const std::string path = command != nullptr ? command_path(command) + " " : "";
  return std::string("Run '") + program + " " + path + "--help' for " +
         (command != nullptr ? "its options." : "the commands.");
}

int usage_error(CLI::App& cli, const CLI::ParseError& e, int argc, const char* const* argv, const char* program,
                std::ostream& err) {
  std::string unknown;
  CLI::App* command = named_command(cli, argc, argv, unknown);
  const CLI::App& scope = command != nullptr ? *command : cli;
  if (!unknown.empty()) {
    std::vector<std::string> names;
    for (CLI::App* c : commands_of(command != nullptr ? *command : cli)) names.push_back(c->get_name());
    const std::string guess = closest(unknown, names);
    err << program << ": error: unknown command '" << unknown << "'"
        << (guess.empty() ? "" : "; did you mean '" + guess + "'?") << "\n"
        << usage_hint(command, program) << "\n";
    return 2;
  }
  for (int i = 1; i < argc; ++i) {
    const std::string token = argv[i];
    if (token.rfind("--", 0) != 0 || token == "--" || is_option_of(scope, token) || is_option_of(cli, token)) continue;
    const std::string name = token.substr(0, token.find('='));
    const std::string guess = closest(name, long_names(scope));
    err << program << ": error: unknown option '" << name << "'"
        << (command != nullptr ? " for '" + command_path(command) + "'" : "")
        << (guess.empty() ? "" : "; did you mean '" + guess + "'?") << "\n"
        << usage_hint(command, program) << "\n";
    return 2;
  }
  err << program << ": error: " << e.what() << "\n" << usage_hint(command, program) << "\n";
  return 2;
}

}  // namespace

CLI::Validator positive_number() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        double v = 0.0;
        if (!CLI::detail::lexical_cast(value, v)) return "not a number: " + value;
        if (!(v > 0.0) || !std::isfinite(v)) return "must be a number > 0, got " + value;
        return {};
      },
      "NUMBER > 0", "positive");
}

int run_cli(CLI::App& cli, int argc, const char* const* argv, const char* program, std::ostream& out,
            std::ostream& err) {
  if (argc <= 1 && cli.get_require_subcommand_min() > 0) {
    print_short_help(cli, program, out);
    return 0;
  }
  refuse_signed_unsigned(cli);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return cli.exit(e, out, err);  // --help, --version
    return usage_error(cli, e, argc, argv, program, err);
  } catch (const CommandExit& e) {
    return e.status();
  } catch (const InputError& e) {
    err << program << ": error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    err << program << ": error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace gyrotc::app
