#!/bin/bash
# Prints the ROS_LANG_DISABLE value of this workspace's builds: the installed message generators
# of languages the robot does not use (Lisp; on Ubuntu also EusLisp and Node.js). Only Python
# and C++ messages are generated, a fifth less build time on the 2-core machine. Naming a
# generator that is not installed would make CMake warn, hence the check.
out=""
for g in genlisp geneus gennodejs; do
  if rospack find "$g" >/dev/null 2>&1; then out="${out:+$out:}$g"; fi
done
echo "$out"
