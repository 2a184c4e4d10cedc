// The seed devices' profiles, compiled in from profiles/*.toml.
#include <vector>

#include "profiles/profile.hpp"
// After <vector>: the generated file is a list of the profile files' texts.
#include "bundled_profiles_data.inc"

namespace rtuscope {

const std::vector<Profile>& bundled_profiles() {
    // A bundled profile that does not load is a build mistake that the unit tests catch
    // (BundledProfiles.AllLoadWithoutProblems); at run time it is left out.
    static const std::vector<Profile> profiles = [] {
        std::vector<Profile> loaded;
        for (const BundledProfileFile& file : kBundledProfileFiles) {
            ProfileLoad load = load_profile_text(file.text, std::string("<bundled>/") + file.name);
            if (load.profile && load.problems.empty()) loaded.push_back(std::move(*load.profile));
        }
        return loaded;
    }();
    return profiles;
}

std::vector<ProfileProblem> bundled_profile_problems() {
    std::vector<ProfileProblem> problems;
    for (const BundledProfileFile& file : kBundledProfileFiles) {
        ProfileLoad load = load_profile_text(file.text, std::string("<bundled>/") + file.name);
        problems.insert(problems.end(), load.problems.begin(), load.problems.end());
    }
    return problems;
}

std::size_t bundled_profile_file_count() {
    return kBundledProfileFiles.size();
}

}  // namespace rtuscope
