// Strict config reading (TOML via toml++, JSON via nlohmann) from text, then a
// walk over the result with ConfigTable the way the readers use it.
#include "fuzz_support.h"

#include <rtsim/workloads/config_reader.h>

RTSIM_FUZZ_TARGET(config_text) {
  if (size == 0) return 0;
  // First byte picks the syntax, the rest is the document.
  const bool toml = data[0] & 1;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  rtsim::fuzz::expect_only_input_errors([&] {
    const nlohmann::json doc = rtsim::parse_config_text(text, toml ? "fuzz.toml" : "fuzz.json", toml);
    if (!doc.is_object()) return;
    rtsim::ConfigTable root(doc, "fuzz");
    for (const auto& item : doc.items()) {
      const std::string& key = item.key();
      const nlohmann::json& v = item.value();
      if (v.is_string()) root.string(key, "");
      else if (v.is_boolean()) root.boolean(key, false);
      else if (v.is_number_integer()) root.integer(key, 0, INT64_MIN, INT64_MAX);
      else if (v.is_number()) root.number(key, 0.0, -1e300, 1e300);
      else if (v.is_array() && v.size() == 3) root.vector3(key, rtsim::vec3(0.0f));
      else if (v.is_array()) for (rtsim::ConfigTable& t : root.array_of_tables(key)) t.finish();
      else if (v.is_object()) root.table(key).finish();
    }
    root.finish();
  });
  return 0;
}
