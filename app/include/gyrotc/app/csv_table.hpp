#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace gyrotc::app {

// A CSV file with a header row, read whole. Cells stay text until a column is
// asked for as numbers, so files with descriptive columns (fig26) read fine.
// Every error is an InputError naming the file, and the line and column where
// there is one: "data.csv:7: column 'gyro_mv': 'abc' is not a number".
// Blank lines and lines starting with '#' are skipped.
class CsvTable {
 public:
  static CsvTable read(const std::string& path);
  // Parses text as if it were the content of a file called `name`.
  static CsvTable parse(std::string_view text, const std::string& name);

  const std::string& path() const { return path_; }
  const std::vector<std::string>& columns() const { return columns_; }
  std::size_t rows() const { return cells_.size(); }
  bool has(std::string_view column) const;
  // 1-based line number of data row `row` in the file.
  std::size_t line_of(std::size_t row) const { return lines_.at(row); }

  // The column as finite doubles; throws naming the line of a bad cell, or
  // the missing column and the columns that are there.
  std::vector<double> numbers(std::string_view column) const;
  std::vector<std::string> text(std::string_view column) const;

  // Throws if the column's values are not strictly increasing (e.g. time_s).
  void require_increasing(std::string_view column) const;

 private:
  std::size_t index_of(std::string_view column) const;

  std::string path_;
  std::vector<std::string> columns_;
  std::vector<std::vector<std::string>> cells_;
  std::vector<std::size_t> lines_;
};

}  // namespace gyrotc::app
