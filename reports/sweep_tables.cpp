#include "reports/sweep_tables.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

#include "analysis/sweep.h"
#include "analysis/zero_dynamics.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "base/vocabulary.h"
#include "reports/sweep_columns.h"
#include "reports/sweep_records.h"

namespace servokit {
namespace {

// The shortest exact text of a number (AppendExact), remembered for the next row: writing
// numbers is most of a cheap sweep's cost, and many repeat bit for bit (the first eigenvalue's
// real part is max_real_part; a conjugate pair's rows share their real part, frequency and
// damping ratio).
class ExactText {
 public:
  // Appends the text of `value`, formatting it only when it differs from the last one's bits.
  void Append(std::string& csv, double value) {
    constexpr std::uint64_t kSignBit = std::uint64_t{1} << 63;
    const auto bits = std::bit_cast<std::uint64_t>(value);
    if (valid_ && bits == (bits_ ^ kSignBit) && value != 0.0 && !std::isnan(value)) {
      // The shortest text of -x is "-" and that of x: a conjugate's imaginary part.
      if (text_.front() == '-') {
        text_.erase(0, 1);
      } else {
        text_.insert(0, 1, '-');
      }
      bits_ = bits;
    } else if (!valid_ || bits != bits_) {
      text_.clear();
      AppendExact(text_, value);
      bits_ = bits;
      valid_ = true;
    }
    csv += text_;
  }

 private:
  std::string text_;
  std::uint64_t bits_ = 0;
  bool valid_ = false;
};

// The texts of the numbers of a point's rows (max_real_part, and per eigenvalue its real and
// imaginary parts, frequency and damping ratio), kept from row to row by ExactText.
struct RowNumberTexts {
  ExactText real_part, imaginary_part, frequency, damping_ratio;
};

void AppendPointRow(const std::string& values,
                    const SweepPoint& point,
                    RowNumberTexts& texts,
                    std::string& csv) {
  csv += values;
  if (!point.ok) {
    csv += ",,,,,,,";  // the seven class columns are empty
    csv += CsvQuote(point.error);
    csv += '\n';
    return;
  }
  csv += ToString(point.realization);
  csv += ',';
  AppendShortest(csv, point.rank);
  csv += ',';
  // A negative internal order: the structure at infinity was not determined (a large linear
  // model whose Markov rows vanish numerically): its three columns are empty, not numbers.
  if (point.internal_dynamics_order >= 0) {
    AppendRelativeDegrees(csv, point.relative_degree);
    csv += ',';
    AppendShortest(csv, point.differentiation_index);
    csv += ',';
    AppendShortest(csv, point.internal_dynamics_order);
    csv += ',';
  } else {
    csv += ",,,";
  }
  csv += ToString(point.stability);
  csv += ',';
  // NaN means no eigenvalues (SweepPoint): an empty field, not "nan".
  if (!std::isnan(point.max_real_part)) texts.real_part.Append(csv, point.max_real_part);
  csv += ",\n";  // empty error
}

void AppendEigenvalueRows(const std::string& values,
                          const SweepPoint& point,
                          RowNumberTexts& texts,
                          std::string& csv) {
  for (std::size_t k = 0; k < point.eigenvalues.size(); ++k) {
    const std::complex<double> eigenvalue = point.eigenvalues[k];
    // ModeOf depends on |Re| and |Im| alone: a conjugate's mode is its partner's, bit for bit.
    const Mode mode = ModeOf(eigenvalue);
    csv += values;
    AppendShortest(csv, k);
    csv += ',';
    texts.real_part.Append(csv, eigenvalue.real());
    csv += ',';
    texts.imaginary_part.Append(csv, eigenvalue.imag());
    csv += ',';
    texts.frequency.Append(csv, mode.frequency_hz);
    csv += ',';
    texts.damping_ratio.Append(csv, mode.damping_ratio);
    csv += '\n';
  }
}

}  // namespace

void AppendCsvRows(const ParameterGrid& grid,
                   std::size_t first,
                   std::span<const SweepPoint> points,
                   std::string& points_csv,
                   std::string& eigenvalues_csv) {
  const std::vector<GridAxis>& axes = grid.axes();
  // The parameter columns' text, each axis's formatted again only when its value index changes
  // (in a grid, all but the fastest axis stay put from row to row).
  std::vector<std::size_t> indices(axes.size()), shown(axes.size(), SIZE_MAX);
  std::vector<std::string> axis_texts(axes.size());
  std::string value_columns;
  RowNumberTexts texts;
  for (std::size_t i = 0; i < points.size(); ++i) {
    grid.PointIndices(first + i, indices);
    if (indices != shown) {
      value_columns.clear();
      for (std::size_t axis = 0; axis < axes.size(); ++axis) {
        if (indices[axis] != shown[axis]) {
          axis_texts[axis].clear();
          AppendExact(axis_texts[axis], axes[axis].DisplayValue(axes[axis].Value(indices[axis])));
          shown[axis] = indices[axis];
        }
        value_columns += axis_texts[axis];
        value_columns += ',';
      }
    }
    AppendPointRow(value_columns, points[i], texts, points_csv);
    AppendEigenvalueRows(value_columns, points[i], texts, eigenvalues_csv);
  }
}

namespace {

// Rows of points first, first + 1, ... in the encoding's form, replacing the texts' contents.
void FormatRows(const ParameterGrid& grid,
                std::size_t first,
                std::span<const SweepPoint> points,
                TableEncoding encoding,
                std::string& points_text,
                std::string& eigenvalues_text) {
  points_text.clear();
  eigenvalues_text.clear();
  if (encoding == TableEncoding::kCsv) {
    AppendCsvRows(grid, first, points, points_text, eigenvalues_text);
  } else {  // records (their rows are decoded by PipelinedBlockFormatter)
    AppendRecordRows(first, points, points_text, eigenvalues_text);
  }
}

std::size_t CountWithoutSolution(std::span<const SweepPoint> points) {
  return static_cast<std::size_t>(std::count_if(points.begin(), points.end(),
                                                [](const SweepPoint& point) { return !point.ok; }));
}

}  // namespace

void FormatBlock(const ParameterGrid& grid,
                 std::size_t first,
                 std::span<const SweepPoint> points,
                 int threads,
                 TableEncoding encoding,
                 FormattedBlock& block) {
  // Formatting numbers costs about a tenth of a small model's analysis: done on one thread it
  // would cap the speed-up of many cores, so each thread formats one contiguous slice and the
  // slices are written in order (the bytes do not depend on the number of slices).
  const auto slices = static_cast<std::size_t>(std::max(threads, 1));
  block.first = first;
  block.points = points.size();
  block.points_without_solution = CountWithoutSolution(points);
  block.points_csv.resize(slices);
  block.eigenvalues_csv.resize(slices);
  ParallelFor(slices, static_cast<int>(slices), 1, [&](std::size_t slice, int) {
    const std::size_t begin = points.size() * slice / slices;
    const std::size_t end = points.size() * (slice + 1) / slices;
    // Formatted into locals: the slices' string objects sit side by side, and a size field
    // written by two threads at once would bounce its cache line between them.
    std::string points_csv = std::move(block.points_csv[slice]);
    std::string eigenvalues_csv = std::move(block.eigenvalues_csv[slice]);
    FormatRows(grid, first + begin, points.subspan(begin, end - begin), encoding, points_csv,
               eigenvalues_csv);
    block.points_csv[slice] = std::move(points_csv);
    block.eigenvalues_csv[slice] = std::move(eigenvalues_csv);
  });
}

PipelinedBlockFormatter::PipelinedBlockFormatter(const ParameterGrid& grid,
                                                 TableEncoding encoding,
                                                 std::size_t block_size,
                                                 std::size_t chunk_size)
    : grid_(grid), encoding_(encoding), chunk_size_(chunk_size) {
  const std::size_t chunks = (block_size + chunk_size - 1) / chunk_size;
  const bool rows = encoding == TableEncoding::kRecordsAndRows;
  for (FormattedBlock& block : blocks_) {
    block.points_csv.resize(chunks);
    block.eigenvalues_csv.resize(chunks);
    block.points_rows.resize(rows ? chunks : 0);
    block.eigenvalue_rows.resize(rows ? chunks : 0);
  }
  if (rows) decoder_ = std::make_unique<RecordDecoder>(grid);
}

PipelinedBlockFormatter::~PipelinedBlockFormatter() = default;

void PipelinedBlockFormatter::FormatChunk(int slot,
                                          std::size_t chunk,
                                          std::size_t first,
                                          std::span<const SweepPoint> points) {
  FormattedBlock& block = blocks_[static_cast<std::size_t>(slot)];
  // The slices were sized by the constructor, so threads formatting other chunks never move
  // these strings; each string's own buffer is written by this thread alone.
  FormatRows(grid_, first, points, encoding_, block.points_csv[chunk],
             block.eigenvalues_csv[chunk]);
  if (decoder_) {
    decoder_->DecodePoints(block.points_csv[chunk], first, block.points_rows[chunk]);
    decoder_->DecodeEigenvalues(block.eigenvalues_csv[chunk], block.eigenvalue_rows[chunk]);
  }
}

const FormattedBlock& PipelinedBlockFormatter::Block(int slot,
                                                     std::size_t first,
                                                     std::span<const SweepPoint> points) {
  FormattedBlock& block = blocks_[static_cast<std::size_t>(slot)];
  const std::size_t chunks = (points.size() + chunk_size_ - 1) / chunk_size_;
  // Only the last block of a sweep can be shorter; its unused slices must not be written.
  for (std::size_t chunk = chunks; chunk < block.points_csv.size(); ++chunk) {
    block.points_csv[chunk].clear();
    block.eigenvalues_csv[chunk].clear();
    if (decoder_) block.points_rows[chunk].rows = block.eigenvalue_rows[chunk].rows = 0;
  }
  block.first = first;
  block.points = points.size();
  block.points_without_solution = CountWithoutSolution(points);
  return block;
}

}  // namespace servokit
