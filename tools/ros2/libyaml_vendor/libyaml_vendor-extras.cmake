# Debian's libyaml (libyaml-dev), exported as libyaml_vendor's libraries and include folders.
find_library(rosguard_libyaml_library NAMES yaml)
find_path(rosguard_libyaml_include_dir NAMES yaml.h)
if(NOT rosguard_libyaml_library OR NOT rosguard_libyaml_include_dir)
  message(FATAL_ERROR "libyaml_vendor (rosguard's stand-in): Debian's libyaml not found; "
                      "apt-get install libyaml-dev")
endif()
list(APPEND libyaml_vendor_LIBRARIES "${rosguard_libyaml_library}")
list(APPEND libyaml_vendor_INCLUDE_DIRS "${rosguard_libyaml_include_dir}")
