#include "gyrotc/app/csv_table.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "gyrotc/app/errors.hpp"

namespace gyrotc::app {
namespace {

std::string trim(std::string_view s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  std::string out(s.substr(b, e - b));
  if (out.size() >= 2 && out.front() == '"' && out.back() == '"') out = out.substr(1, out.size() - 2);
  return out;
}

std::vector<std::string> split(std::string_view line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  bool quoted = false;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i < line.size() && line[i] == '"') quoted = !quoted;
    if (i == line.size() || (line[i] == ',' && !quoted)) {
      out.push_back(trim(line.substr(start, i - start)));
      start = i + 1;
    }
  }
  return out;
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
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path + ": read error");
  return parse(text.str(), path);
}

CsvTable CsvTable::parse(std::string_view text, const std::string& name) {
  CsvTable t;
  t.path_ = name;
  std::size_t line_no = 0;
  std::size_t pos = 0;
  bool have_header = false;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    if (skippable(line)) continue;
    auto fields = split(line);
    if (!have_header) {
      for (std::size_t i = 0; i < fields.size(); ++i) {
        if (fields[i].empty())
          throw InputError(name + ":" + std::to_string(line_no) + ": header column " +
                           std::to_string(i + 1) + " has no name");
        for (std::size_t j = 0; j < i; ++j)
          if (fields[j] == fields[i])
            throw InputError(name + ":" + std::to_string(line_no) + ": column '" + fields[i] +
                             "' appears twice in the header");
      }
      t.columns_ = std::move(fields);
      have_header = true;
      continue;
    }
    if (fields.size() != t.columns_.size())
      throw InputError(name + ":" + std::to_string(line_no) + ": " + std::to_string(fields.size()) +
                       " fields, but the header has " + std::to_string(t.columns_.size()));
    t.cells_.push_back(std::move(fields));
    t.lines_.push_back(line_no);
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

std::vector<double> CsvTable::numbers(std::string_view column) const {
  const std::size_t col = index_of(column);
  std::vector<double> out;
  out.reserve(cells_.size());
  for (std::size_t r = 0; r < cells_.size(); ++r) {
    const std::string& cell = cells_[r][col];
    const std::string where =
        path_ + ":" + std::to_string(lines_[r]) + ": column '" + std::string(column) + "': ";
    if (cell.empty()) throw InputError(where + "empty cell");
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(cell.c_str(), &end);
    if (end == cell.c_str() || *end != '\0') throw InputError(where + "'" + cell + "' is not a number");
    if (!std::isfinite(v) || errno == ERANGE) throw InputError(where + "'" + cell + "' is not a finite number");
    out.push_back(v);
  }
  return out;
}

std::vector<std::string> CsvTable::text(std::string_view column) const {
  const std::size_t col = index_of(column);
  std::vector<std::string> out;
  out.reserve(cells_.size());
  for (const auto& row : cells_) out.push_back(row[col]);
  return out;
}

void CsvTable::require_increasing(std::string_view column) const {
  const auto v = numbers(column);
  for (std::size_t r = 1; r < v.size(); ++r)
    if (!(v[r] > v[r - 1]))
      throw InputError(path_ + ":" + std::to_string(lines_[r]) + ": column '" + std::string(column) +
                       "' must increase (" + cells_[r][index_of(column)] + " after " +
                       cells_[r - 1][index_of(column)] + ")");
}

}  // namespace gyrotc::app
