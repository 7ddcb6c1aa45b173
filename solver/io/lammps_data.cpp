#include "io/lammps_data.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <map>
#include <sstream>

#include "io/files.hpp"

namespace celldem {
namespace {

// One line of the file: its number, the words before any '#', and the words of the comment.
struct Line {
  int number = 0;
  std::vector<std::string> words;
  std::vector<std::string> comment;
};

std::vector<std::string> split_words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

std::string join(const std::vector<std::string>& words, std::size_t from = 0) {
  std::string s;
  for (std::size_t k = from; k < words.size(); ++k) s += (k > from ? " " : "") + words[k];
  return s;
}

bool starts_with_letter(const std::string& word) {
  return !word.empty() && std::isalpha(static_cast<unsigned char>(word[0]));
}

// The file's problems, located: "<source>:<line>: <what>".
class Reporter {
 public:
  explicit Reporter(std::string source) : source_(std::move(source)) {}
  [[noreturn]] void fail(int line, const std::string& what) const {
    throw LammpsDataError(source_ + ":" + std::to_string(line) + ": " + what);
  }

 private:
  std::string source_;
};

double parse_real(const Reporter& r, const Line& line, std::size_t k, const char* what) {
  const std::string& w = line.words[k];
  const char* begin = w.data() + (w[0] == '+' ? 1 : 0);
  double x = 0.0;
  const auto res = std::from_chars(begin, w.data() + w.size(), x);
  if (res.ec != std::errc() || res.ptr != w.data() + w.size())
    r.fail(line.number, std::string(what) + ": \"" + w + "\" is not a number");
  if (!std::isfinite(x)) r.fail(line.number, std::string(what) + ": \"" + w + "\" is not finite");
  return x;
}

std::int64_t parse_integer(const Reporter& r, const Line& line, std::size_t k, const char* what) {
  const std::string& w = line.words[k];
  const char* begin = w.data() + (w[0] == '+' ? 1 : 0);
  std::int64_t x = 0;
  const auto res = std::from_chars(begin, w.data() + w.size(), x);
  if (res.ec != std::errc() || res.ptr != w.data() + w.size())
    r.fail(line.number, std::string(what) + ": \"" + w + "\" is not an integer");
  return x;
}

// The header: counts and box. Missing values stay unset until validated.
struct Header {
  std::int64_t atoms = -1;
  std::int64_t atom_types = -1;
  double low[3] = {0, 0, 0}, high[3] = {0, 0, 0};
  int box_line[3] = {0, 0, 0};  // line of each axis's bounds (0: missing)
};

void read_header_line(const Reporter& r, const Line& line, Header& h) {
  const std::vector<std::string>& w = line.words;
  const std::string keyword = join(w, w.size() >= 2 ? w.size() - 2 : 0);
  const std::string last = w.back();
  static const char* kAxisKeyword[3] = {"xlo xhi", "ylo yhi", "zlo zhi"};
  for (int k = 0; k < 3; ++k)
    if (w.size() == 4 && keyword == kAxisKeyword[k]) {
      h.low[k] = parse_real(r, line, 0, kAxisKeyword[k]);
      h.high[k] = parse_real(r, line, 1, kAxisKeyword[k]);
      if (!(h.low[k] < h.high[k])) r.fail(line.number, std::string(kAxisKeyword[k]) + ": the low bound must be below the high one");
      h.box_line[k] = line.number;
      return;
    }
  if (w.size() == 6 && join(w, 3) == "xy xz yz") {
    for (std::size_t k = 0; k < 3; ++k)
      if (parse_real(r, line, k, "xy xz yz") != 0.0)
        r.fail(line.number, "triclinic boxes are not supported (xy xz yz = " + w[0] + " " + w[1] + " " + w[2] +
                                "): celldem reads orthogonal boxes only");
    return;
  }
  if (last == "avec" || last == "bvec" || last == "cvec" || keyword == "abc origin")
    r.fail(line.number, "general triclinic boxes (" + keyword + ") are not supported: celldem reads orthogonal boxes only");
  if (w.size() == 2 && last == "atoms") {
    h.atoms = parse_integer(r, line, 0, "atoms");
    if (h.atoms < 0) r.fail(line.number, "atoms: the count must not be negative");
    return;
  }
  if (w.size() == 3 && keyword == "atom types") {
    h.atom_types = parse_integer(r, line, 0, "atom types");
    if (h.atom_types < 1) r.fail(line.number, "atom types: there must be at least one");
    return;
  }
  // Topology and body counts: atom_style sphere has none.
  static const char* kNone[] = {"bonds", "angles", "dihedrals", "impropers", "ellipsoids", "lines", "triangles", "bodies"};
  if (w.size() == 2 && std::find(std::begin(kNone), std::end(kNone), last) != std::end(kNone)) {
    if (parse_integer(r, line, 0, last.c_str()) != 0)
      r.fail(line.number, "\"" + join(w) + "\": atom_style sphere has no " + last);
    return;
  }
  // "N bond types", "N extra bond per atom", ...: nothing of the spheres.
  if (last == "types" || (w.size() >= 2 && w[1] == "extra")) return;
  r.fail(line.number, "unrecognised header line \"" + join(w) + "\"");
}

struct Section {
  int header_line = 0;
  std::vector<Line> lines;
};

struct AtomLine {
  std::int64_t id;
  int type;
  double diameter, density;
  Vec3 x;
  Vec3 image;
  int line;
};

// Lines, with comments split off. The first line is the title.
std::vector<Line> data_lines(const std::string& text) {
  std::vector<Line> lines;
  std::istringstream in(text);
  std::string raw;
  for (int number = 1; std::getline(in, raw); ++number) {
    if (number == 1) continue;
    const std::size_t hash = raw.find('#');
    Line line;
    line.number = number;
    line.words = split_words(raw.substr(0, hash));
    if (hash != std::string::npos) line.comment = split_words(raw.substr(hash + 1));
    if (!line.words.empty()) lines.push_back(std::move(line));
  }
  return lines;
}

// Atoms: id type diameter density x y z [ix iy iz], in ascending id order (a duplicate id fails).
std::vector<AtomLine> read_atoms(const Reporter& report, const Section& atoms, const Header& header) {
  std::vector<AtomLine> atom_lines;
  for (const Line& line : atoms.lines) {
    const std::size_t columns = line.words.size();
    if (columns != 7 && columns != 10)
      report.fail(line.number, "Atoms: expected 7 or 10 columns (id type diameter density x y z [ix iy iz]), found " +
                                   std::to_string(columns));
    AtomLine a;
    a.line = line.number;
    a.id = parse_integer(report, line, 0, "atom id");
    if (a.id < 1) report.fail(line.number, "atom id " + std::to_string(a.id) + ": ids must be positive");
    const std::int64_t type = parse_integer(report, line, 1, "atom type");
    if (type < 1 || type > header.atom_types)
      report.fail(line.number, "atom type " + std::to_string(type) + " is outside 1.." + std::to_string(header.atom_types));
    a.type = static_cast<int>(type);
    a.diameter = parse_real(report, line, 2, "diameter");
    if (!(a.diameter > 0.0)) report.fail(line.number, "diameter " + line.words[2] + ": must be positive");
    a.density = parse_real(report, line, 3, "density");
    if (!(a.density > 0.0)) report.fail(line.number, "density " + line.words[3] + ": must be positive");
    for (int k = 0; k < 3; ++k) a.x[k] = parse_real(report, line, 4 + k, "position");
    a.image = Vec3::Zero();
    if (columns == 10)
      for (int k = 0; k < 3; ++k) a.image[k] = static_cast<double>(parse_integer(report, line, 7 + k, "image flag"));
    atom_lines.push_back(a);
  }
  std::sort(atom_lines.begin(), atom_lines.end(), [](const AtomLine& a, const AtomLine& b) { return a.id < b.id; });
  for (std::size_t k = 1; k < atom_lines.size(); ++k)
    if (atom_lines[k].id == atom_lines[k - 1].id)
      report.fail(std::max(atom_lines[k].line, atom_lines[k - 1].line),
                  "duplicate atom id " + std::to_string(atom_lines[k].id) + " (also on line " +
                      std::to_string(std::min(atom_lines[k].line, atom_lines[k - 1].line)) + ")");
  return atom_lines;
}

// Velocities: id vx vy vz wx wy wz, one line for every atom.
void read_velocities(const Reporter& report, const Section& velocities,
                     const std::map<std::int64_t, std::size_t>& index_of_id, LammpsData& out) {
  State& s = out.state;
  const std::size_t n = out.ids.size();
  out.has_velocities = true;
  std::vector<int> seen_on(n, 0);
  for (const Line& line : velocities.lines) {
    if (line.words.size() != 7)
      report.fail(line.number, "Velocities: expected 7 columns (id vx vy vz wx wy wz), found " +
                                   std::to_string(line.words.size()));
    const std::int64_t id = parse_integer(report, line, 0, "atom id");
    const auto found = index_of_id.find(id);
    if (found == index_of_id.end())
      report.fail(line.number, "Velocities: atom id " + std::to_string(id) + " is not in the Atoms section");
    const std::size_t i = found->second;
    if (seen_on[i] != 0)
      report.fail(line.number, "Velocities: duplicate atom id " + std::to_string(id) + " (also on line " +
                                   std::to_string(seen_on[i]) + ")");
    seen_on[i] = line.number;
    for (int k = 0; k < 3; ++k) s.particles.velocity[i][k] = parse_real(report, line, 1 + k, "velocity");
    for (int k = 0; k < 3; ++k) s.particles.spin[i][k] = parse_real(report, line, 4 + k, "angular velocity");
  }
  for (std::size_t i = 0; i < n; ++i)
    if (seen_on[i] == 0)
      report.fail(velocities.header_line,
                  "Velocities: no line for atom id " + std::to_string(out.ids[i]) + " (every atom needs one)");
}

}  // namespace

LammpsData parse_lammps_data(const std::string& text, const std::string& source) {
  const Reporter report(source);
  const std::vector<Line> lines = data_lines(text);

  // The header runs up to the first section keyword (a line starting with a letter; header lines start
  // with a number).
  Header header;
  std::size_t at = 0;
  for (; at < lines.size() && !starts_with_letter(lines[at].words[0]); ++at) read_header_line(report, lines[at], header);

  // Sections: their data lines, up to the next keyword.
  std::optional<Section> atoms, velocities;
  while (at < lines.size()) {
    const Line& keyword_line = lines[at++];
    const std::string name = join(keyword_line.words);
    Section section;
    section.header_line = keyword_line.number;
    for (; at < lines.size() && !starts_with_letter(lines[at].words[0]); ++at) section.lines.push_back(lines[at]);
    if (name == "Atoms") {
      const std::string style = keyword_line.comment.empty() ? "sphere" : keyword_line.comment[0];
      if (style != "sphere" && style != "granular")
        report.fail(keyword_line.number, "unsupported atom style \"" + style +
                                             "\": only atom_style sphere (id type diameter density x y z) is read");
      if (atoms) report.fail(keyword_line.number, "a second Atoms section");
      atoms = std::move(section);
    } else if (name == "Velocities") {
      if (velocities) report.fail(keyword_line.number, "a second Velocities section");
      velocities = std::move(section);
    } else if (name == "Masses" || keyword_line.words.back() == "Coeffs") {
      // Per-type constants: not part of the state.
    } else {
      report.fail(keyword_line.number, "unsupported section \"" + name + "\" (atom_style sphere data files hold "
                                       "Atoms, Velocities and, skipped here, Masses and ... Coeffs)");
    }
  }

  // The header must describe the box and the atoms.
  if (header.atoms < 0) report.fail(0, "no \"N atoms\" header line");
  if (header.atom_types < 0) report.fail(0, "no \"N atom types\" header line");
  static const char* kAxisKeyword[3] = {"xlo xhi", "ylo yhi", "zlo zhi"};
  for (int k = 0; k < 3; ++k)
    if (header.box_line[k] == 0) report.fail(0, std::string("no \"") + kAxisKeyword[k] + "\" header line");
  if (!atoms) report.fail(0, "no Atoms section");
  if (static_cast<std::int64_t>(atoms->lines.size()) != header.atoms)
    report.fail(atoms->header_line, "the Atoms section has " + std::to_string(atoms->lines.size()) +
                                        " lines, but the header says " + std::to_string(header.atoms) + " atoms");

  const std::vector<AtomLine> atom_lines = read_atoms(report, *atoms, header);

  // The state: particles in ascending id order.
  LammpsData out;
  out.atom_types = static_cast<int>(header.atom_types);
  const std::size_t n = atom_lines.size();
  State& s = out.state;
  Vec3 length;
  for (int k = 0; k < 3; ++k) {
    out.box_low[k] = header.low[k];
    length[k] = header.high[k] - header.low[k];
  }
  s.cell.h = length.asDiagonal();
  s.particles.resize(n);
  std::map<std::int64_t, std::size_t> index_of_id;
  for (std::size_t i = 0; i < n; ++i) {
    const AtomLine& a = atom_lines[i];
    index_of_id[a.id] = i;
    out.ids.push_back(a.id);
    out.types.push_back(a.type);
    out.density.push_back(a.density);
    s.particles.radius[i] = 0.5 * a.diameter;
    s.particles.scaled[i] = (a.x - out.box_low).cwiseQuotient(length) + a.image;
  }
  if (n > 0 && std::all_of(out.density.begin(), out.density.end(), [&](double d) { return d == out.density[0]; }))
    out.common_density = out.density[0];

  if (velocities) read_velocities(report, *velocities, index_of_id, out);

  // A new sample's control memory: the cell as it is is the reference.
  s.control.reference.head<3>() = length;
  s.control.reference_volume = s.cell.volume();
  return out;
}

LammpsData read_lammps_data(const std::filesystem::path& path) {
  std::string text;
  try {
    text = read_file(path);
  } catch (const IoError& e) {
    throw LammpsDataError(e.what());  // "<path>: cannot read: <reason>"
  }
  return parse_lammps_data(text, path.string());
}

}  // namespace celldem
