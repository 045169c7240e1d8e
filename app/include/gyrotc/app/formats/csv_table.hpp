#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace gyrotc::app {

// A CSV file with a header row, read whole. Cells stay text until a column is
// asked for as numbers, so files with descriptive columns (fig26) read fine.
// The text is held once and every cell is a view into it (about 16 bytes a
// cell besides the file itself), so a 10^7-sample record fits in memory.
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
  std::size_t rows() const { return lines_.size(); }
  bool has(std::string_view column) const;
  // 1-based line number of data row `row` in the file.
  std::size_t line_of(std::size_t row) const { return lines_.at(row); }

  // The column as finite doubles; throws naming the line of a bad cell, or
  // the missing column and the columns that are there.
  std::vector<double> numbers(std::string_view column) const;
  // As numbers(), but a cell "nan" (a writer's "no value in this period",
  // e.g. no sensor reading yet) is NaN.
  std::vector<double> numbers_or_nan(std::string_view column) const;
  std::vector<std::string> text(std::string_view column) const;

  // Throws if the column's values are not strictly increasing (e.g. time_s).
  void require_increasing(std::string_view column) const;

 private:
  static CsvTable parse_owned(std::string text, const std::string& name);
  std::vector<double> parse_numbers(std::string_view column, bool nan_allowed) const;
  std::size_t index_of(std::string_view column) const;
  std::string_view cell(std::size_t row, std::size_t col) const { return cells_[row * columns_.size() + col]; }

  std::string path_;
  std::shared_ptr<const std::string> text_;  // owned apart: moving the table keeps the views valid
  std::vector<std::string> columns_;
  std::vector<std::string_view> cells_;  // row-major, into *text_
  std::vector<std::uint32_t> lines_;     // 1-based file line of each data row
};

}  // namespace gyrotc::app
