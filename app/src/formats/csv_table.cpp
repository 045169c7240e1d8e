#include "gyrotc/app/formats/csv_table.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <system_error>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {
namespace {

std::string_view trim(std::string_view s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  s = s.substr(b, e - b);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
  return s;
}

// The fields of one line, appended to `out`; returns how many.
std::size_t split(std::string_view line, std::vector<std::string_view>& out) {
  std::size_t count = 0;
  std::size_t start = 0;
  bool quoted = false;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i < line.size() && line[i] == '"') quoted = !quoted;
    if (i == line.size() || (line[i] == ',' && !quoted)) {
      out.push_back(trim(line.substr(start, i - start)));
      ++count;
      start = i + 1;
    }
  }
  return count;
}

bool skippable(std::string_view line) {
  for (char c : line) {
    if (c == '#') return true;
    if (c != ' ' && c != '\t' && c != '\r') return false;
  }
  return true;
}

}  // namespace

CsvTable CsvTable::read(const std::string& path) {
  // A folder opens as a stream on Linux and fails only on the first read;
  // `simulate --out` writes one, with the record inside it.
  std::error_code kind_error;
  if (std::filesystem::is_directory(path, kind_error)) {
    const std::filesystem::path record = std::filesystem::path(path) / "record.csv";
    std::string message = path + ": is a folder, not a CSV file";
    if (std::filesystem::is_regular_file(record, kind_error)) message += " (did you mean " + record.string() + "?)";
    throw InputError(message);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open: " + std::strerror(errno));
  std::string text;
  std::error_code size_error;
  const auto size = std::filesystem::file_size(path, size_error);  // fails for a pipe: then it grows
  if (!size_error) text.reserve(static_cast<std::size_t>(size));
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) text.append(buffer, static_cast<std::size_t>(in.gcount()));
  if (in.bad()) throw InputError(path + ": read error: " + std::strerror(errno));
  return parse_owned(std::move(text), path);
}

CsvTable CsvTable::parse(std::string_view text, const std::string& name) { return parse_owned(std::string(text), name); }

CsvTable CsvTable::parse_owned(std::string owned, const std::string& name) {
  CsvTable t;
  t.path_ = name;
  t.text_ = std::make_shared<const std::string>(std::move(owned));
  const std::string_view text = *t.text_;
  std::size_t line_no = 0;
  std::size_t pos = 0;
  bool have_header = false;
  std::vector<std::string_view> header;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    if (skippable(line)) continue;
    if (!have_header) {
      split(line, header);
      for (std::size_t i = 0; i < header.size(); ++i) {
        if (header[i].empty())
          throw InputError(name + ":" + std::to_string(line_no) + ": header column " + std::to_string(i + 1) +
                           " has no name");
        for (std::size_t j = 0; j < i; ++j)
          if (header[j] == header[i])
            throw InputError(name + ":" + std::to_string(line_no) + ": column '" + std::string(header[i]) +
                             "' appears twice in the header");
        t.columns_.emplace_back(header[i]);
      }
      have_header = true;
      continue;
    }
    const std::size_t fields = split(line, t.cells_);
    if (fields != t.columns_.size())
      throw InputError(name + ":" + std::to_string(line_no) + ": " + std::to_string(fields) +
                       " fields, but the header has " + std::to_string(t.columns_.size()));
    if (line_no > std::numeric_limits<std::uint32_t>::max())
      throw InputError(name + ":" + std::to_string(line_no) + ": too many lines");
    t.lines_.push_back(static_cast<std::uint32_t>(line_no));
  }
  if (!have_header) throw InputError(name + ": empty file (no header row)");
  return t;
}

bool CsvTable::has(std::string_view column) const {
  for (const auto& c : columns_)
    if (c == column) return true;
  return false;
}

std::size_t CsvTable::index_of(std::string_view column) const {
  for (std::size_t i = 0; i < columns_.size(); ++i)
    if (columns_[i] == column) return i;
  std::string have;
  for (const auto& c : columns_) have += (have.empty() ? "" : ", ") + c;
  throw InputError(path_ + ": missing column '" + std::string(column) + "' (columns: " + have + ")");
}

std::vector<double> CsvTable::numbers(std::string_view column) const { return parse_numbers(column, false); }

std::vector<double> CsvTable::numbers_or_nan(std::string_view column) const { return parse_numbers(column, true); }

std::vector<double> CsvTable::parse_numbers(std::string_view column, bool nan_allowed) const {
  const std::size_t col = index_of(column);
  std::vector<double> out;
  out.reserve(rows());
  for (std::size_t r = 0; r < rows(); ++r) {
    const std::string_view text = cell(r, col);
    const auto where = [&] {
      return path_ + ":" + std::to_string(lines_[r]) + ": column '" + std::string(column) + "': ";
    };
    if (text.empty()) throw InputError(where() + "empty cell");
    if (nan_allowed && (text == "nan" || text == "-nan" || text == "NaN")) {
      out.push_back(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    // from_chars takes no leading '+', which a CSV writer may put there.
    const std::string_view digits = text.front() == '+' ? text.substr(1) : text;
    double v = 0.0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
    if (ec == std::errc::result_out_of_range)
      throw InputError(where() + "'" + std::string(text) + "' is not a finite number");
    const bool sign_twice = text.front() == '+' && !digits.empty() && (digits.front() == '-' || digits.front() == '+');
    if (digits.empty() || sign_twice || ec != std::errc{} || end != digits.data() + digits.size())
      throw InputError(where() + "'" + std::string(text) + "' is not a number");
    if (!std::isfinite(v)) throw InputError(where() + "'" + std::string(text) + "' is not a finite number");
    out.push_back(v);
  }
  return out;
}

std::vector<std::string> CsvTable::text(std::string_view column) const {
  const std::size_t col = index_of(column);
  std::vector<std::string> out;
  out.reserve(rows());
  for (std::size_t r = 0; r < rows(); ++r) out.emplace_back(cell(r, col));
  return out;
}

void CsvTable::require_increasing(std::string_view column) const {
  const auto v = numbers(column);
  const std::size_t col = index_of(column);
  for (std::size_t r = 1; r < v.size(); ++r)
    if (!(v[r] > v[r - 1]))
      throw InputError(path_ + ":" + std::to_string(lines_[r]) + ": column '" + std::string(column) +
                       "' must increase (" + std::string(cell(r, col)) + " after " + std::string(cell(r - 1, col)) +
                       ")");
}

}  // namespace gyrotc::app
