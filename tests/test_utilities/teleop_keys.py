"""Pre-shared key files for process tests (link.security.mode psk, docs/security.md).

The shipped UDP configs say `key_file: teleop.key`, relative to the config file; a test that writes its configs into
a work directory puts one key there (ensure_key), so both processes read the same file. The file is created the way
teleop-keygen creates it: 64 hex digits, mode 0600 whatever the umask, never world-readable in between.
"""
import os
import secrets


def write_key(path):
    """A fresh random key at `path` (replacing any file there), mode 0600."""
    if os.path.lexists(path):
        os.remove(path)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write(secrets.token_hex(32) + "\n")
    os.chmod(path, 0o600)
    return path


def ensure_key(directory, name="teleop.key"):
    """The key `name` in `directory`: kept when it is already a private 64-hex-digit file, else written anew."""
    path = os.path.join(directory, name)
    try:
        st = os.stat(path)
        text = open(path).read().strip()
        if (st.st_mode & 0o077) == 0 and len(text) == 64 and all(c in "0123456789abcdefABCDEF" for c in text):
            return path
    except OSError:
        pass
    return write_key(path)


def make_insecure(config_text):
    """A config's `link.security` block replaced by `security: {mode: insecure}` (tests that need version-1
    datagrams on the wire, e.g. to dissect them)."""
    out, skipping, indent = [], False, 0
    for line in config_text.split("\n"):
        stripped = line.lstrip()
        if skipping:
            if stripped and len(line) - len(stripped) > indent:
                continue
            skipping = False
        if stripped.startswith("security:"):
            indent = len(line) - len(stripped)
            out.append(" " * indent + "security: {mode: insecure}")
            skipping = not stripped[len("security:"):].split("#")[0].strip()
            continue
        out.append(line)
    return "\n".join(out)
