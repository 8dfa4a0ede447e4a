// Build-time generator: writes modelDescription.xml and documentation/index.html of one FMU
// from its ModelInfo (the same table the FMU uses at run time).
//   <Name>_gen [--fmi3 | --fmi3-se] <out-dir> [<source file>...]
//                               writes <out-dir>/modelDescription.xml, <out-dir>/documentation/index.html
//                               and ModelInfo::resources into <out-dir>/resources/; source files
//                               (names in sources/) make it a source FMU's description; --fmi3:
//                               the FMI 3.0 Co-Simulation description of the same table
//   <Name>_gen --markdown [--causality C]
//                               prints the variable table (its variables of causality C, e.g.
//                               input) as Markdown (for docs/)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "fmuglue/glue.hpp"

using namespace fmuglue;

namespace {
// A Markdown table cell: '|' would end the cell.
std::string markdownCell(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '|') o += '\\';
    o += c;
  }
  return o;
}

std::string g(double v) {
  if (std::isnan(v)) return "";
  char b[40];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}
std::string startText(const Variable& v) {
  Initial i = effectiveInitial(v);
  if (v.causality != Causality::Input && i == Initial::Calculated) return "(calculated)";
  if (v.type == Type::String) return v.start_string;
  if (v.type == Type::Boolean) return v.start != 0.0 ? "true" : "false";
  return g(v.start);
}
std::string html(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else o += c;
  }
  return o;
}

void usage(std::ostream& o, const char* prog) {
  o << "usage: " << prog << " [--fmi3 | --fmi3-se] <out-dir> [<source file>...]\n"
    << "       " << prog << " --markdown [--causality C]\n\n"
    << "Generates the FMU's description from its variable table (the table the binary uses at run time):\n"
    << "  <out-dir>       an existing folder: writes modelDescription.xml, documentation/index.html and\n"
    << "                  the model's resources/ files into it; <source file>s (names in sources/) make it\n"
    << "                  a source FMU's description. The build runs this when it packs the FMU.\n"
    << "  --fmi3          the FMI 3.0 Co-Simulation twin's description (same table; default FMI 2.0)\n"
    << "  --fmi3-se       the FMI 3.0 Scheduled Execution variant's description (ModelInfo::clock)\n"
    << "  --markdown      prints the variable table as Markdown (docs/, scripts/update_docs.py);\n"
    << "  --causality C   with --markdown: only the variables of causality C (input, output, parameter, ...)\n"
    << "  -h, --help      this text\n"
    << "SOURCE_DATE_EPOCH, when set, is the generationDateAndTime (reproducible builds).\n";
}
}  // namespace

int main(int argc, char** argv) {
  const char* prog = argv[0];
  const bool se = argc >= 2 && std::string(argv[1]) == "--fmi3-se";
  const bool fmi3 = se || (argc >= 2 && std::string(argv[1]) == "--fmi3");
  if (fmi3) {
    --argc;
    ++argv;
  }
  if (argc >= 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    usage(std::cout, prog);
    return 0;
  }
  if (argc < 2 || (argv[1][0] == '-' && std::string(argv[1]) != "--markdown")) {
    if (argc >= 2) std::cerr << prog << ": unknown option " << argv[1] << "\n";
    usage(std::cerr, prog);
    return 2;
  }
  const ModelInfo& info = modelInfo();
  std::string problems = validateModelInfo(info);
  if (!problems.empty()) {
    std::cerr << info.model_name << ": invalid variable table:\n" << problems;
    return 1;
  }
  if (se && !(info.clock.interval > 0.0)) {
    std::cerr << prog << ": " << info.model_name << " declares no Scheduled Execution clock (ModelInfo::clock)\n";
    return 2;
  }
  if (std::string(argv[1]) == "--markdown") {
    const bool filter = argc == 4 && std::string(argv[2]) == "--causality";
    if (argc != 2 && !filter) {
      usage(std::cerr, prog);
      return 2;
    }
    auto shown = [&](const Variable& v) { return !filter || xmlName(v.causality) == std::string(argv[3]); };
    if (std::none_of(info.variables.begin(), info.variables.end(), shown)) {
      std::cerr << prog << ": no variable of causality " << argv[3] << "\n";
      return 2;
    }
    std::cout << "| name | vr | type | causality | variability | unit | start | min | max | description |\n"
              << "|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& v : info.variables)
      if (shown(v))
        std::cout << "| `" << v.name << "` | " << v.vr << " | " << xmlTypeName(v) << " | " << xmlName(v.causality)
                << " | " << xmlName(v.variability) << " | " << v.unit << " | " << startText(v) << " | "
                << g(v.min) << " | " << g(v.max) << " | " << markdownCell(v.description) << " |\n";
    return 0;
  }
  std::string dir = argv[1];
  if (!std::filesystem::is_directory(dir)) {
    std::cerr << prog << ": output folder " << dir << " does not exist\n";
    return 1;
  }
  const std::vector<std::string> source_files(argv + 2, argv + argc);
  {
    std::ofstream f(dir + "/modelDescription.xml", std::ios::binary);
    f << (se ? modelDescriptionXmlSE(info) : fmi3 ? modelDescriptionXml3(info) : modelDescriptionXml(info, source_files));
    if (!f) { std::cerr << "cannot write " << dir << "/modelDescription.xml\n"; return 1; }
  }
  {
    std::ofstream f(dir + "/documentation/index.html", std::ios::binary);
    f << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" << html(info.model_name)
      << "</title></head><body>\n<h1>" << html(info.model_name) << "</h1>\n<p>" << html(info.description)
      << "</p>\n<p>"
      << (se     ? "FMI 3.0 Scheduled Execution FMU (one model partition: every input and output clocked by the "
                   "input clock " + info.clock.name + "), instantiation token "
          : fmi3 ? "FMI 3.0 Co-Simulation FMU, instantiation token "
                 : "FMI 2.0 co-simulation FMU, GUID ")
      << modelGuid(info) << ". Default experiment: "
      << g(info.default_experiment.start_time) << " to " << g(info.default_experiment.stop_time)
      << " s, step " << g(info.default_experiment.step_size) << " s.</p>\n"
      << "<p>Log categories: logEvents, logStatusWarning, logStatusDiscard, logStatusError, logStatusFatal, logCalls";
    for (const auto& c : info.extra_log_categories) f << ", " << html(c.name);
    f << ".</p>\n<table border=\"1\" cellspacing=\"0\" cellpadding=\"3\">\n<tr><th>name</th><th>vr</th><th>type</th>"
         "<th>causality</th><th>variability</th><th>unit</th><th>start</th><th>min</th><th>max</th><th>description</th></tr>\n";
    for (const auto& v : info.variables)
      f << "<tr><td>" << html(v.name) << "</td><td>" << v.vr << "</td><td>" << xmlTypeName(v) << "</td><td>"
        << xmlName(v.causality) << "</td><td>" << xmlName(v.variability) << "</td><td>" << html(v.unit)
        << "</td><td>" << html(startText(v)) << "</td><td>" << g(v.min) << "</td><td>" << g(v.max) << "</td><td>"
        << html(v.description) << "</td></tr>\n";
    f << "</table>\n";
    if (fmi3 && !info.arrays.empty()) {  // FMI 3.0: the arrays, views of the variables above
      f << "<h2>Float64 arrays (FMI 3.0)</h2>\n<p>Each is the listed variables' values, row-major; reading or "
           "setting it reads or sets them.</p>\n<table border=\"1\" cellspacing=\"0\" cellpadding=\"3\">\n"
           "<tr><th>name</th><th>vr</th><th>dimensions</th><th>elements</th><th>description</th></tr>\n";
      for (const auto& a : info.arrays) {
        std::string dims, elements;
        for (int d : a.dimensions) dims += (dims.empty() ? "" : " x ") + std::to_string(d);
        for (fmi2ValueReference r : a.elements)
          for (const auto& v : info.variables)
            if (v.vr == r) elements += (elements.empty() ? "" : ", ") + v.name;
        f << "<tr><td>" << html(a.name) << "</td><td>" << a.vr << "</td><td>" << dims << "</td><td>" << html(elements)
          << "</td><td>" << html(a.description) << "</td></tr>\n";
      }
      f << "</table>\n";
    }
    f << "</body></html>\n";
    if (!f) { std::cerr << "cannot write " << dir << "/documentation/index.html\n"; return 1; }
  }
  if (!info.resources.empty()) std::filesystem::create_directories(dir + "/resources");
  for (const auto& [file, content] : info.resources) {
    std::ofstream f(dir + "/resources/" + file, std::ios::binary);
    f << content;
    if (!f) { std::cerr << "cannot write " << dir << "/resources/" << file << "\n"; return 1; }
  }
  return 0;
}
