// The layer order of docs/architecture.md, read from the document itself, against every #include
// of include/, src/ and python/src/: a file may include dronetwin headers of its own folder and
// of folders of lower layers only, and the heavy dependencies (yaml-cpp, Ceres, pybind11) only
// where the document allows them. A folder the document does not list fails too, so the document
// cannot fall behind the tree.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const fs::path kRoot = DRONETWIN_SOURCE_DIR;

struct Layers {
  std::map<std::string, int> rank;                            // folder -> layer rank
  std::map<std::string, std::set<std::string>> dependencies;  // folder -> allowed externals
};

// The fenced block after "<!-- layers: read by tests/architecture/layering_test.cpp -->": one
// layer per line, "rank  folders...  [| externals...]".
Layers read_layers() {
  std::ifstream in(kRoot / "docs/architecture.md");
  EXPECT_TRUE(in) << "docs/architecture.md is missing";
  std::string line;
  bool marker = false, inside = false;
  Layers layers;
  while (std::getline(in, line)) {
    if (line.find("<!-- layers:") != std::string::npos) marker = true;
    if (!marker) continue;
    if (line.rfind("```", 0) == 0) {
      if (inside) break;
      inside = true;
      continue;
    }
    if (!inside || line.empty()) continue;
    const std::size_t bar = line.find('|');
    std::istringstream words(line.substr(0, bar));
    int rank = -1;
    words >> rank;
    std::set<std::string> externals;
    if (bar != std::string::npos) {
      std::istringstream ext(line.substr(bar + 1));
      for (std::string e; ext >> e;) externals.insert(e);
    }
    for (std::string folder; words >> folder;) {
      EXPECT_EQ(layers.rank.count(folder), 0u) << folder << " listed twice";
      layers.rank[folder] = rank;
      layers.dependencies[folder] = externals;
    }
  }
  EXPECT_GT(layers.rank.size(), 10u) << "no layer table found in docs/architecture.md";
  return layers;
}

struct Source {
  fs::path path;
  std::string folder;  // the layer folder it belongs to
};

// Every C++ file of the library, the programs and the bindings, with its folder.
std::vector<Source> sources() {
  std::vector<Source> out;
  const auto add_tree = [&](const fs::path& root, bool folder_is_first_component) {
    for (const auto& e : fs::recursive_directory_iterator(root)) {
      if (!e.is_regular_file()) continue;
      const std::string ext = e.path().extension().string();
      if (ext != ".cpp" && ext != ".hpp") continue;
      const fs::path rel = fs::relative(e.path(), root);
      out.push_back({e.path(), folder_is_first_component ? rel.begin()->string() : "python"});
    }
  };
  add_tree(kRoot / "include/dronetwin", true);
  add_tree(kRoot / "src", true);
  add_tree(kRoot / "python/src", false);
  return out;
}

struct Include {
  bool quoted = false;  // "..." (else <...>)
  std::string target;
};

// The target of an #include line. No std::regex: GCC 12's -Wmaybe-uninitialized misfires inside
// it in the sanitizer build.
std::optional<Include> include_of(const std::string& line) {
  std::size_t i = line.find_first_not_of(" \t");
  if (i == std::string::npos || line[i] != '#') return std::nullopt;
  i = line.find_first_not_of(" \t", i + 1);
  if (i == std::string::npos || line.compare(i, 7, "include") != 0) return std::nullopt;
  i = line.find_first_not_of(" \t", i + 7);
  if (i == std::string::npos || (line[i] != '"' && line[i] != '<')) return std::nullopt;
  const char close = line[i] == '"' ? '"' : '>';
  const std::size_t end = line.find(close, i + 1);
  if (end == std::string::npos) return std::nullopt;
  return Include{close == '"', line.substr(i + 1, end - i - 1)};
}

TEST(Layering, EveryIncludeGoesDownTheDocumentedLayerOrder) {
  const Layers layers = read_layers();
  // Outside libraries by the start of their include path.
  const std::map<std::string, std::string> external_name = {
      {"yaml-cpp/", "yaml-cpp"},     {"ceres/", "ceres"},       {"pybind11/", "pybind11"},
      {"experimental/simd", "simd"}, {"ros/", "ros"},           {"nav_msgs/", "ros"},
      {"sensor_msgs/", "ros"},       {"geometry_msgs/", "ros"}, {"std_msgs/", "ros"},
      {"tf2_msgs/", "ros"},          {"rosgraph_msgs/", "ros"}, {"visualization_msgs/", "ros"}};
  const std::string own_prefix = "dronetwin/";
  std::size_t includes_checked = 0;
  for (const Source& s : sources()) {
    const auto self = layers.rank.find(s.folder);
    ASSERT_NE(self, layers.rank.end())
        << s.path << ": folder '" << s.folder << "' is not in the layer table of "
        << "docs/architecture.md";
    std::ifstream in(s.path);
    std::string line;
    int line_no = 0;
    while (std::getline(in, line)) {
      ++line_no;
      const std::optional<Include> inc = include_of(line);
      if (!inc) continue;
      const std::string& path = inc->target;
      if (inc->quoted && path.rfind(own_prefix, 0) == 0) {
        ++includes_checked;
        const std::size_t slash = path.find('/', own_prefix.size());
        ASSERT_NE(slash, std::string::npos) << s.path << ":" << line_no << ": " << path;
        const std::string target = path.substr(own_prefix.size(), slash - own_prefix.size());
        const auto it = layers.rank.find(target);
        ASSERT_NE(it, layers.rank.end()) << s.path << ":" << line_no << ": includes folder '"
                                         << target << "', which the layer table does not list";
        EXPECT_TRUE(target == s.folder || it->second < self->second)
            << s.path << ":" << line_no << ": " << s.folder << " (layer " << self->second
            << ") includes " << target << " (layer " << it->second
            << "): dependencies must run down the layers of docs/architecture.md";
      } else if (inc->quoted) {
        // A private header beside the file: same folder by construction.
        EXPECT_EQ(path.find('/'), std::string::npos)
            << s.path << ":" << line_no << ": quoted include " << path;
        EXPECT_TRUE(fs::exists(s.path.parent_path() / path))
            << s.path << ":" << line_no << ": " << path << " is not beside the file";
      } else {
        for (const auto& [prefix, dep] : external_name) {
          if (path.rfind(prefix, 0) != 0) continue;
          EXPECT_TRUE(layers.dependencies.at(s.folder).count(dep))
              << s.path << ":" << line_no << ": " << s.folder << " includes <" << path
              << ">; docs/architecture.md allows " << dep << " only in other layers";
        }
      }
    }
  }
  EXPECT_GT(includes_checked, 200u);
}

TEST(Layering, TheTableItselfIsReadAsDocumented) {
  // A few facts the rest of the project relies on: the core is below everything, yaml-cpp is the
  // config layer's alone, Ceres the NMPC's, the fits' and the time-optimal lap's.
  const Layers layers = read_layers();
  for (const char* core : {"core", "math", "model", "dynamics", "sim"})
    EXPECT_LT(layers.rank.at(core), layers.rank.at("control")) << core;
  std::vector<std::string> yaml_users, ceres_users;
  for (const auto& [folder, deps] : layers.dependencies) {
    if (deps.count("yaml-cpp")) yaml_users.push_back(folder);
    if (deps.count("ceres")) ceres_users.push_back(folder);
  }
  EXPECT_EQ(yaml_users, std::vector<std::string>{"config"});
  EXPECT_EQ(ceres_users, (std::vector<std::string>{"identification", "nmpc", "time_optimal"}));
}

}  // namespace
