#!/bin/sh
# find_sundials.sh -- find a SUNDIALS >= 7 to link this program against (written by
# `gearsym export`).  Prints the linker arguments (full library paths and an rpath) on
# stdout, or says what is wrong on stderr and exits 1.
#
# Where it looks, in this order:
#   1. SUNDIALS_LIBDIR  a folder holding libsundials_core, _cvode, _ida, _nvecserial,
#                       _sunmatrixdense, _sunlinsoldense (*.so*)
#   2. SUNDIALS_DIR     an install prefix (or its lib/cmake/sundials folder)
#   3. BUNDLED_LIBDIR   the libraries shipped with this project (lib/, copied at export
#                       from the scikit-sundae wheel), linked by relative path with the
#                       run path $ORIGIN/lib: the program finds them beside itself
#   4. pkg-config       modules sundials-cvode / sundials_cvode, if the install has them
#   5. CMake packages   SUNDIALSConfig.cmake under CMAKE_PREFIX_PATH, /usr/local, /usr,
#                       /opt/sundials*; and headers + libraries under those prefixes
# An explicit choice (1, 2) that does not fit is an error; an automatic find (3, 4, 5) that
# does not fit is skipped with a note.
#
# What fits: SUNDIALS >= 7 (the driver uses the v7 API: SUNContext_Create(SUNComm),
# the error-handler stack, SUNLogger FILE* setters; SUNDIALS 6 lacks them and has no
# libsundials_core), double precision and 32-bit sunindextype (the driver's own
# declarations in sundials7.h; the program checks both again when it starts).

STEMS="sundials_cvode sundials_ida sundials_sunlinsoldense sundials_sunmatrixdense sundials_nvecserial sundials_core"

note() { echo "find_sundials: $*" >&2; }

# check_headers INCLUDEDIR -> 0 fits, 1 does not (reason in $WHY), 2 no headers there
check_headers() {
  cfg="$1/sundials/sundials_config.h"
  [ -f "$cfg" ] || return 2
  major=$(sed -n 's/^#define SUNDIALS_VERSION_MAJOR \([0-9]*\).*/\1/p' "$cfg" | head -n 1)
  if [ -z "$major" ]; then
    major=$(sed -n 's/^#define SUNDIALS_VERSION "\([0-9]*\)\..*/\1/p' "$cfg" | head -n 1)
  fi
  version=$(sed -n 's/^#define SUNDIALS_VERSION "\([^"]*\)".*/\1/p' "$cfg" | head -n 1)
  if [ -z "$major" ]; then WHY="cannot read the version from $cfg"; return 1; fi
  if [ "$major" -lt 7 ]; then
    WHY="SUNDIALS $version ($cfg) is too old: this program needs SUNDIALS >= 7 (the driver uses the v7 API)"
    return 1
  fi
  if grep -q '^#define SUNDIALS_INT64_T' "$cfg"; then
    WHY="SUNDIALS $version ($cfg) uses 64-bit sunindextype; the driver's declarations (sundials7.h) assume 32-bit (rebuild SUNDIALS with -DSUNDIALS_INDEX_SIZE=32, or use the scikit-sundae wheel's libraries)"
    return 1
  fi
  if grep -q '^#define SUNDIALS_SINGLE_PRECISION\|^#define SUNDIALS_EXTENDED_PRECISION' "$cfg"; then
    WHY="SUNDIALS $version ($cfg) is not built in double precision"
    return 1
  fi
  return 0
}

# find_libs LIBDIR -> sets LIBS (full paths, link order), 0 if all found
find_libs() {
  LIBS=""
  for stem in $STEMS; do
    f=""
    for cand in "$1/lib$stem.so" "$1"/lib"$stem".so.* "$1"/lib"$stem"-*.so*; do
      if [ -f "$cand" ]; then f="$cand"; break; fi
    done
    if [ -z "$f" ]; then
      if [ "$stem" = sundials_core ] && [ -n "$LIBS" ]; then
        WHY="no libsundials_core in $1: that is SUNDIALS < 7; this program needs SUNDIALS >= 7"
      else
        WHY="lib$stem not found in $1"
      fi
      return 1
    fi
    LIBS="$LIBS $f"
  done
  # without headers, the version is in the library file name (libsundials_cvode*.so.MAJOR...)
  cv=$(echo "$LIBS" | tr ' ' '\n' | grep sundials_cvode | head -n 1)
  real=$(readlink -f "$cv" 2>/dev/null || echo "$cv")
  major=$(basename "$real" | sed -n 's/.*\.so\.\([0-9][0-9]*\).*/\1/p')
  if [ -n "$major" ] && [ "$major" -lt 7 ]; then
    WHY="$real is SUNDIALS $major; this program needs SUNDIALS >= 7"
    return 1
  fi
  return 0
}

emit() {
  echo "-Wl,-rpath,$1$LIBS"
  exit 0
}

# try_prefix PREFIX EXPLICIT
try_prefix() {
  prefix="$1"
  case "$prefix" in
    */lib/cmake/sundials|*/lib64/cmake/sundials) prefix=$(cd "$prefix/../../.." && pwd) ;;
  esac
  check_headers "$prefix/include"
  hrc=$?
  if [ $hrc -eq 1 ]; then
    if [ "$2" = 1 ]; then note "$WHY"; exit 1; fi
    note "skipping: $WHY"
    return 1
  fi
  for libdir in "$prefix/lib" "$prefix/lib64" "$prefix/lib/x86_64-linux-gnu" "$prefix/lib/aarch64-linux-gnu"; do
    [ -d "$libdir" ] || continue
    if find_libs "$libdir"; then emit "$libdir"; fi
    case "$WHY" in *"SUNDIALS <"*|*"needs SUNDIALS >= 7"*)
      if [ "$2" = 1 ]; then note "$WHY"; exit 1; fi
      note "skipping: $WHY"; return 1 ;;
    esac
  done
  if [ "$2" = 1 ]; then note "no SUNDIALS libraries under $prefix ($WHY)"; exit 1; fi
  return 1
}

# 1. SUNDIALS_LIBDIR
if [ -n "$SUNDIALS_LIBDIR" ]; then
  if find_libs "$SUNDIALS_LIBDIR"; then emit "$SUNDIALS_LIBDIR"; fi
  note "SUNDIALS_LIBDIR=$SUNDIALS_LIBDIR: $WHY"
  exit 1
fi

# 2. SUNDIALS_DIR
if [ -n "$SUNDIALS_DIR" ]; then
  try_prefix "$SUNDIALS_DIR" 1
fi

# 3. the libraries shipped in the project (a relative folder: found beside the program)
if [ -n "$BUNDLED_LIBDIR" ] && [ -d "$BUNDLED_LIBDIR" ]; then
  case "$BUNDLED_LIBDIR" in
    /*) note "BUNDLED_LIBDIR must be relative to the project folder"; exit 1 ;;
  esac
  if find_libs "$BUNDLED_LIBDIR"; then emit "\$ORIGIN/$BUNDLED_LIBDIR"; fi
  note "skipping $BUNDLED_LIBDIR: $WHY"
elif [ -n "$BUNDLED_LIBDIR" ]; then
  note "no $BUNDLED_LIBDIR/ folder (the SUNDIALS libraries shipped at export; re-export to get it): looking elsewhere"
fi

# 4. pkg-config
if command -v pkg-config >/dev/null 2>&1; then
  for mod in sundials-cvode sundials_cvode; do
    if pkg-config --exists "$mod" 2>/dev/null; then
      libdir=$(pkg-config --variable=libdir "$mod")
      incdir=$(pkg-config --variable=includedir "$mod")
      check_headers "$incdir"
      if [ $? -eq 1 ]; then note "skipping pkg-config $mod: $WHY"; continue; fi
      if find_libs "$libdir"; then emit "$libdir"; fi
      note "skipping pkg-config $mod: $WHY"
    fi
  done
fi

# 5. CMake packages and standard prefixes
OLDIFS=$IFS
IFS=:
for p in $CMAKE_PREFIX_PATH; do
  IFS=$OLDIFS
  [ -n "$p" ] && [ -d "$p" ] && try_prefix "$p" 0
  IFS=:
done
IFS=$OLDIFS
for p in /usr/local /opt/sundials* /usr; do
  [ -d "$p" ] || continue
  if [ -f "$p/include/sundials/sundials_config.h" ] || ls "$p"/lib*/cmake/sundials/SUNDIALSConfig.cmake >/dev/null 2>&1 \
     || ls "$p"/lib/*/cmake/sundials/SUNDIALSConfig.cmake >/dev/null 2>&1; then
    try_prefix "$p" 0
  fi
done

note "no SUNDIALS >= 7 found.  Install SUNDIALS >= 7 (32-bit indices) and run"
note "  make SUNDIALS_DIR=/its/prefix    or    make SUNDIALS_LIBDIR=/folder/with/the/libraries"
note "or use the libraries of the scikit-sundae wheel (pip install scikit-sundae):"
note "  make SUNDIALS_LIBDIR=\$(python3 -c 'import sksundae, pathlib; print(pathlib.Path(sksundae.__file__).parents[1] / \"scikit_sundae.libs\")')"
exit 1
