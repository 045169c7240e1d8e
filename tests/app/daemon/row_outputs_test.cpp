#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "gyrotc/app/daemon/row_outputs.hpp"
#include "gyrotc/app/runtime/record_columns.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using gyrotc::app::OutputRow;
using gyrotc::app::RowOutputs;
using gyrotc::app::RowOutputsConfig;
using gyrotc::app::StreamKind;

namespace {

std::string fresh_path(const std::string& name) {
  const std::string path = gyrotc::test::scratch_dir() + "/row_outputs_" + name;
  std::filesystem::remove(path);
  return path;
}

std::string text_of(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int count_of(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// A row a calibration can use (a casing reading, samples), stamped `time_s`.
OutputRow row(double time_s) {
  OutputRow r;
  r.time_s = time_s;
  r.casing_c = 40.0;
  r.samples = 10;
  r.have_casing = true;
  return r;
}

RowOutputsConfig record_to(const std::string& path) {
  RowOutputsConfig c;
  c.output.stream = StreamKind::none;
  c.output.record_csv = path;
  return c;
}

}  // namespace

TEST_CASE("a reload that keeps the record's path goes on in the same file, its header once") {
  const std::string csv = fresh_path("same.csv");
  RowOutputs outputs(record_to(csv));
  outputs.write(row(1.0));
  RowOutputsConfig again = record_to(csv);
  again.output.status_interval_s = 5.0;  // other [output] keys changed
  again.output.write_timeout_s = 2.0;    // the record's own: still not a reason to truncate it
  CHECK(outputs.reconfigure(again).empty());
  outputs.write(row(2.0));
  outputs.flush();
  const std::string text = text_of(csv);
  CHECK(count_of(text, "time_s,") == 1);
  CHECK(count_of(text, "\n1.000,") == 1);
  CHECK(count_of(text, "\n2.000,") == 1);
}

TEST_CASE("a reload to a new record path: the rows before stay in the old file, the rows after go to the new") {
  const std::string first = fresh_path("first.csv");
  const std::string second = fresh_path("second.csv");
  RowOutputs outputs(record_to(first));
  outputs.write(row(1.0));
  CHECK(outputs.reconfigure(record_to(second)) == "record " + second);
  outputs.write(row(2.0));
  outputs.flush();
  const std::string old_text = text_of(first);
  const std::string new_text = text_of(second);
  CHECK(old_text.rfind("time_s,", 0) == 0);
  CHECK(new_text.rfind("time_s,", 0) == 0);
  CHECK(count_of(old_text, "\n1.000,") == 1);
  CHECK(count_of(old_text, "\n2.000,") == 0);
  CHECK(count_of(new_text, "\n2.000,") == 1);
  CHECK(count_of(new_text, "\n1.000,") == 0);
}

TEST_CASE("a reload to a record path that cannot be written is refused naming the key, and the rows go on") {
  const std::string csv = fresh_path("kept.csv");
  RowOutputs outputs(record_to(csv));
  outputs.write(row(1.0));
  const std::string blocked = fresh_path("a-file");
  std::ofstream(blocked) << "not a folder\n";
  CHECK_THROWS_WITH(outputs.reconfigure(record_to(blocked + "/record.csv")),
                    Catch::Contains("output.record_csv"));
  outputs.write(row(2.0));
  outputs.flush();
  CHECK(count_of(text_of(csv), "\n2.000,") == 1);
}

TEST_CASE("a stream turned on by a reload starts with the header and gets every row after it") {
  const std::string csv = fresh_path("record.csv");
  const std::string stream = fresh_path("stream.csv");
  RowOutputs outputs(record_to(csv));
  outputs.write(row(1.0));
  RowOutputsConfig with_stream = record_to(csv);
  with_stream.output.stream = StreamKind::file;
  with_stream.output.path = stream;
  CHECK(outputs.reconfigure(with_stream) == "stream file " + stream);
  OutputRow early = row(2.0);
  early.have_casing = false;  // not for the record, but the stream shows it
  outputs.write(early);
  outputs.flush();
  const std::string text = text_of(stream);
  CHECK(text.rfind(std::string(gyrotc::app::kRecordCsvHeader) + "\n", 0) == 0);
  CHECK(count_of(text, "\n2.000,") == 1);
  CHECK(count_of(text, "\n1.000,") == 0);
  CHECK(count_of(text_of(csv), "\n2.000,") == 0);
}

TEST_CASE("the record moves to .1 past record_max_mb and the new file starts with the header") {
  const std::string csv = fresh_path("rotating.csv");
  std::filesystem::remove(csv + ".1");
  RowOutputsConfig c = record_to(csv);
  c.output.record_max_mb = 0.0003;  // 300 bytes: the header and a few rows
  RowOutputs outputs(c);
  for (int i = 1; i <= 6; ++i) outputs.write(row(i));
  outputs.flush();
  const std::string older = text_of(csv + ".1");
  const std::string current = text_of(csv);
  CHECK(older.rfind("time_s,", 0) == 0);
  CHECK(current.rfind("time_s,", 0) == 0);
  CHECK(older.size() <= 300);
  for (int i = 1; i <= 6; ++i) {
    std::string line_start = "\n";  // appended, not `"\n" + ...`: GCC 12 warns falsely (-Wrestrict) on that
    line_start += std::to_string(i) + ".000,";
    CHECK(count_of(older + current, line_start) == 1);
  }
}

TEST_CASE("`record --out` is never cut, whatever record_max_mb says") {
  const std::string csv = fresh_path("whole.csv");
  std::filesystem::remove(csv + ".1");
  RowOutputsConfig c = record_to(csv);
  c.output.record_max_mb = 0.0003;
  c.rotate = false;
  c.record_key = "--out";
  RowOutputs outputs(c);
  for (int i = 1; i <= 6; ++i) outputs.write(row(i));
  outputs.flush();
  CHECK_FALSE(std::filesystem::exists(csv + ".1"));
  CHECK(count_of(text_of(csv), "\n6.000,") == 1);
}
