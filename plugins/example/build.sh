#!/bin/sh
# Builds the example overlap plugins next to this script: libc_ocsi.so and libc_arvo.so (the
# flags are those their sources explain). Then, from the repository root:
#   sweep run plugins/example/table1.toml --db plugins.db && sweep report table1 --db plugins.db
set -eu
here=$(cd "$(dirname "$0")" && pwd)
cc=${CC:-cc}
for name in ocsi arvo; do
    "$cc" -O2 -ffinite-math-only -fno-signed-zeros -std=c99 -Wall -Werror -shared -fPIC \
        -I "$here/../../include" -o "$here/libc_$name.so" "$here/$name.c"
done
echo "built $here/libc_ocsi.so $here/libc_arvo.so"
