// teleop-keygen PATH: a fresh pre-shared key for link.security.mode psk (docs/security.md, "Key file"): 32 random
// bytes (libsodium) as 64 hex digits, created with mode 0600 whatever the umask; an existing file is never
// overwritten. Copy the same file to both machines (e.g. scp -p, which keeps the mode).
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <string>

#include "teleop/cli_help.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/secure_key_file.hpp"
#include "teleop/version.hpp"

int main(int argc, char** argv) {
  try {
    CLI::App app{"teleop-keygen: write a new pre-shared key file (mode 0600) for link.security.mode psk"};
    app.set_version_flag("--version", teleop::VersionText("teleop-keygen"));
    teleop::StandardHelp(app);
    std::string path;
    app.add_option("path", path, "Key file to create (refused when it exists)")->required();
    CLI11_PARSE(app, argc, argv);
    teleop::transport::WriteNewKeyFile(path);
    // Load it back: the same checks the processes apply (mode, length, content).
    (void)teleop::transport::LoadPreSharedKey(path);
    std::cout << "teleop-keygen: wrote " << path
              << " (mode 0600); use the same file on both ends: link.security {mode: psk, key_file: " << path << "}\n";
    return 0;
  } catch (const teleop::Error& e) {
    std::cerr << "teleop-keygen: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "teleop-keygen: unexpected error: " << e.what() << "\n";
    return 2;
  }
}
