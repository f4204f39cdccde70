#include "build_options.h"

#include <rtsim/builder/builder_registry.h>

#include <map>
#include <string>

namespace rtsim::cli {

void add_build_options(CLI::App* cmd, BuildParams& p) {
  // One flag per parameter of the registry's table that has one.
  for (const BuilderParameter& parameter : builder_parameters()) {
    if (parameter.flag.empty()) continue;
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(p.*member)>;
          if constexpr (std::is_same_v<T, bool>) {
            if (parameter.switch_flag) {
              cmd->add_flag(parameter.flag, p.*member, parameter.description);
            } else {
              cmd->add_option(parameter.flag, p.*member, parameter.description)
                  ->transform(CLI::CheckedTransformer(
                      std::map<std::string, bool>{{"on", true}, {"off", false}}))
                  ->default_str(p.*member ? "on" : "off");
            }
          } else {
            cmd->add_option(parameter.flag, p.*member, parameter.description)->capture_default_str();
          }
        },
        parameter.field);
  }
  cmd->add_option_function<std::vector<std::string>>(
         "--build-set",
         [&p](const std::vector<std::string>& settings) {
           for (const std::string& s : settings) apply_build_setting(p, s, "--build-set");
         },
         "builder parameter KEY=VALUE by its table name (repeatable; docs/builders.md), e.g.\n"
         "max_leaf_size=8; what a campaign's build.KEY axis passes")
      ->type_name("KEY=VALUE")
      ->take_all();
}

}  // namespace rtsim::cli
