#include "reports/plugins.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <vector>

#include "base/errors.h"

namespace servokit {
namespace {

// Where this code lives: the executable or the shared object (the Python module) it is linked
// into.
std::filesystem::path DirectoryOfThisObject() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<const void*>(&PluginSymbol), &info) == 0 ||
      info.dli_fname == nullptr) {
    return {};
  }
  std::error_code error;
  const std::filesystem::path object = std::filesystem::canonical(info.dli_fname, error);
  return error ? std::filesystem::path() : object.parent_path();
}

std::vector<std::filesystem::path> PluginDirectories() {
  std::vector<std::filesystem::path> directories;
  // A program of another project, linked with the installed static libraries, is not beside
  // the plugins: it names their directory (PREFIX/lib/servokit) in SERVOKIT_PLUGIN_DIR.
  if (const char* named = std::getenv("SERVOKIT_PLUGIN_DIR"); named != nullptr && *named) {
    directories.emplace_back(named);
  }
  if (const std::filesystem::path here = DirectoryOfThisObject(); !here.empty()) {
    directories.push_back(here);
    directories.push_back(here.parent_path() / SERVOKIT_PLUGIN_INSTALL_DIR);
  }
  directories.emplace_back(SERVOKIT_PLUGIN_PREFIX_DIR);
  directories.emplace_back(SERVOKIT_PLUGIN_BUILD_DIR);
  return directories;
}

// Loads plugin `name` (its handle is never closed: code from it may still be referenced by
// objects it made, until the process ends).
void* LoadPlugin(const std::string& name) {
  const std::string file = "lib" + name + ".so";
  std::string tried;
  for (const std::filesystem::path& directory : PluginDirectories()) {
    const std::filesystem::path path = directory / file;
    if (!std::filesystem::exists(path)) {
      tried += (tried.empty() ? "" : ", ") + directory.string();
      continue;
    }
    // RTLD_GLOBAL: MPI's own components, loaded by MPI later, resolve its symbols through the
    // global scope.
    if (void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_GLOBAL)) return handle;
    const char* message = dlerror();
    throw Error("cannot load " + path.string() + ": " + (message ? message : "unknown error"));
  }
  throw Error("servokit's plugin " + file + " is missing (looked in " + tried +
              "); it is built with servokit and installed beside it");
}

}  // namespace

void* PluginSymbol(const std::string& plugin, const char* symbol) {
  static std::mutex mutex;
  static std::map<std::string, void*> loaded;
  const std::lock_guard lock(mutex);
  auto found = loaded.find(plugin);
  if (found == loaded.end()) found = loaded.emplace(plugin, LoadPlugin(plugin)).first;
  dlerror();
  void* address = dlsym(found->second, symbol);
  if (address == nullptr) {
    throw Error("servokit's plugin lib" + plugin + ".so has no " + symbol +
                " (is it from another servokit build?)");
  }
  return address;
}

}  // namespace servokit
