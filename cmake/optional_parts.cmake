# gimm's optional parts (gimm::io, gimm::embree, gimm::dicom), each switched by GIMM_WITH_<PART>:
#   AUTO (the default)  on when its packages are found, else off; the configure log says which
#   ON                  required: a missing package is an error naming it and the switch
#   OFF                 left out, its packages not looked for
# A build of gimm's own tests, examples or benchmarks needs every part: there AUTO means ON.
# The resolved ON/OFF is a normal variable shadowing the cache entry, so `if(GIMM_WITH_IO)`
# reads as before.

# The mode of `switch` (AUTO, ON or OFF) in `out`; an unknown value is an error naming it.
function(gimm_part_mode switch required out)
  if(NOT DEFINED ${switch})
    set(${switch} AUTO CACHE STRING
        "AUTO (on when its packages are found), ON (required) or OFF")
    set_property(CACHE ${switch} PROPERTY STRINGS AUTO ON OFF)
  endif()
  string(TOUPPER "${${switch}}" value)
  if(value MATCHES "^(ON|TRUE|YES|Y|1)$")
    set(value ON)
  elseif(value MATCHES "^(OFF|FALSE|NO|N|0)$")
    set(value OFF)
  elseif(NOT value STREQUAL "AUTO")
    message(FATAL_ERROR "gimm: ${switch}=${${switch}}: give AUTO, ON or OFF")
  endif()
  if(value STREQUAL "AUTO" AND required)
    set(value ON)
  endif()
  set(${out} ${value} PARENT_SCOPE)
endfunction()

# After find_package(... QUIET) of `packages`: sets `switch` to ON or OFF (normal variable) and
# says so; with mode ON a missing package is an error naming the switch.
function(gimm_part_result switch mode part hint)
  set(missing "")
  foreach(package ${ARGN})
    if(NOT ${package}_FOUND)
      list(APPEND missing ${package})
    endif()
  endforeach()
  if(missing)
    list(JOIN missing ", " missing_text)
    if(mode STREQUAL "ON")
      message(FATAL_ERROR "gimm: ${switch}=ON (${part}) needs ${missing_text}, not found: "
                          "install ${hint} (scripts/install-deps.sh does), or configure with "
                          "-D${switch}=OFF to build without ${part}")
    endif()
    message(STATUS "gimm: ${part} off: ${missing_text} not found (${hint}; -D${switch}=ON to require it)")
    set(${switch} OFF PARENT_SCOPE)
  else()
    message(STATUS "gimm: ${part} on")
    set(${switch} ON PARENT_SCOPE)
  endif()
endfunction()
