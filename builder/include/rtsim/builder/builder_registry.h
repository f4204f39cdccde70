#pragma once
// The builder registry: one entry per BVH builder and one table of the builders'
// parameters (name, unit, range, which builders read it). Everything that lists
// builders or their knobs reads these two tables: build_bvh's dispatch, parameter
// checks, command-line flags, BVH-file metadata, Table 1's display names and
// campaign axes (`build.KEY = [...]`). A new builder is one file under
// builder/src/builders/ plus one entry in builder_registry.cpp.
#include <rtsim/builder/build.h>

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

namespace rtsim {

struct BuilderInfo {
  std::string name;          // what --builder takes
  std::string display_name;  // Table 1's column heading
  std::string summary;       // one line for --help and docs
  bool ours = false;         // not one of the patent's four trees
  bool splits_references = false;  // a triangle may sit in several leaves
  bool needs_camera = false;       // the tree depends on the workload's camera
  bool casts_rays = false;         // casts Embree rays while building (AO pass, visibility, samples)
  bool builds_wide = false;        // builds N-wide trees itself (no collapse pass)
  // Builds the BLASes of an instanced scene's two-level tree (two_level.cpp). RDH
  // does not: its sample rays are world-space segments a BLAS in object space cannot weigh.
  bool builds_blas = true;
  // Fixed reference budget (x N) of a builder whose budget is not a parameter; 0: the
  // sbvh_reference_budget parameter applies.
  double fixed_reference_budget = 0;
  // Builds the builder's tree (binary unless builds_wide); params already checked.
  Bvh (*build)(const Scene& scene, const BuildParams& params, BuildReport& report) = nullptr;
};

// A BuildParams field as a parameter: what flags, checks, files and campaigns see.
struct BuilderParameter {
  using Field = std::variant<float BuildParams::*, uint32_t BuildParams::*, uint64_t BuildParams::*,
                             bool BuildParams::*, std::string BuildParams::*>;
  std::string key;          // the BuildParams field name; campaign axis build.KEY
  std::string flag;         // command-line flag ("" = set by the command, e.g. --camera)
  std::string unit;         // "" for plain numbers
  std::string description;  // the flag's help text
  Field field;
  // Inclusive range of a number (min_exclusive: min itself not allowed).
  double min = 0, max = 0;
  bool min_exclusive = false;
  bool switch_flag = false;  // bool given as a bare flag (--ao-both-sides); else on/off
  std::vector<std::string> choices;  // a name from this list (empty: any name)
  std::vector<std::string> used_by;  // builders that read it; empty: every builder
  bool in_tree_identity = true;      // written to BVH files and job keys
};

const std::vector<BuilderInfo>& builder_registry();
// InputError naming `where` ("builder" by default) and listing the known names.
const BuilderInfo& builder_info(const std::string& name, const std::string& where = "builder");

const std::vector<BuilderParameter>& builder_parameters();
const BuilderParameter* find_builder_parameter(const std::string& key);  // nullptr if none
bool parameter_used_by(const BuilderParameter& parameter, const std::string& builder);

// Whether params' tree depends on the camera the workload traces (params.camera):
// OSAH's visibility, RDH's sample rays from that camera (not with rdh_cameras = all
// or none, which sample every camera or none).
bool tree_depends_on_camera(const BuildParams& params);

// Sets params.KEY from text ("0.25", "8", "on"/"off"/"true"/"false", a name); InputError
// naming `where` + key for an unknown key or a value that does not parse or lies out
// of range.
void set_build_parameter(BuildParams& params, const std::string& key, const std::string& text,
                         const std::string& where = "build.");
// "KEY=VALUE" (a campaign's build.KEY or --build-set) into params.
void apply_build_setting(BuildParams& params, const std::string& assignment,
                         const std::string& where = "--build-set");

// The value of a parameter as text, the way set_build_parameter reads it.
std::string build_parameter_text(const BuildParams& params, const BuilderParameter& parameter);

}  // namespace rtsim
