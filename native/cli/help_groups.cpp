#include "help_groups.h"

#include <memory>
#include <vector>

namespace ptir::cli {

namespace {

constexpr const char* kAdvanced = "Advanced options (--help-all)";

class CommonOptionsFormatter : public CLI::Formatter {
 public:
  std::string make_help(const CLI::App* app, std::string name, CLI::AppFormatMode mode) const override {
    all_ = mode == CLI::AppFormatMode::All;
    std::string help = CLI::Formatter::make_help(app, name, mode);
    for (size_t at; (at = help.find("\n\n\n")) != std::string::npos;) help.erase(at, 1);  // the empty group's lines
    return help;
  }
  std::string make_group(std::string group, bool positional, std::vector<const CLI::Option*> opts) const override {
    if (group == kAdvanced && !all_) return "";
    return CLI::Formatter::make_group(group, positional, opts);
  }
  std::string make_footer(const CLI::App* app) const override {
    const std::string footer = CLI::Formatter::make_footer(app);
    if (all_) return footer;
    size_t hidden = 0;
    for (const CLI::Option* opt : app->get_options()) hidden += opt->get_group() == kAdvanced;
    return footer + "\n" + std::to_string(hidden) + " more options (schedules, learning rates, loss terms, capture " +
           "and pixel-filter settings): ptir optimize --help-all\n";
  }

 private:
  mutable bool all_ = false;
};

}  // namespace

void show_common_options(CLI::App* cmd, const std::set<std::string>& common) {
  cmd->set_help_all_flag("--help-all", "print every option (--help lists the common ones)");
  for (CLI::Option* opt : cmd->get_options())
    if (!common.count(opt->get_name())) opt->group(kAdvanced);
  cmd->formatter(std::make_shared<CommonOptionsFormatter>());
}

}  // namespace ptir::cli
