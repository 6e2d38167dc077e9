# How servokit's targets link their third-party libraries: shared objects by default; the static
# archives of the same Debian -dev packages in a target whose SERVOKIT_STATIC_THIRD_PARTY
# property is ON (the `servokit` program, application/CMakeLists.txt).
#
# Why (issue #19, start-up): resolving the symbols of 20 shared libraries cost `servokit
# --version` 3.1 of its 4.9 ms of CPU, and `analyze` of the mass on car 7.7 ms instead of 3.7 ms.
# Archives are resolved once, when the program is linked. ARPACK's LAPACK, BLAS and Fortran
# runtime too (another 0.5 ms): in the program ARPACK uses the reference BLAS, whose share of its
# time (products with the n x ncv basis) is small beside the sparse factorisation of the operator;
# the libraries and the Python module keep the BLAS that Debian's alternatives choose. The
# libraries, the plugins and the Python module link shared objects (Debian's archives are not
# position-independent), and so does a project linking the installed package: the choice is a
# generator expression on the head target, and no installed target sets the property.
#
# SERVOKIT_<NAME> below is the link item to put in DEPENDS instead of the library's own target.

option(SERVOKIT_STATIC_THIRD_PARTY
       "Link the servokit program with the static archives of its third-party libraries" ON)

set(SERVOKIT_STATIC_CHOSEN "$<BOOL:$<TARGET_PROPERTY:SERVOKIT_STATIC_THIRD_PARTY>>")
set(SERVOKIT_STATIC_AVAILABLE ${SERVOKIT_STATIC_THIRD_PARTY})

# servokit_archives(<variable> <file>...): the full paths of the archive files, or sets
# SERVOKIT_STATIC_AVAILABLE OFF (and says which is missing) when one is not installed.
function(servokit_archives variable)
  set(paths)
  foreach(file IN LISTS ARGN)
    string(MAKE_C_IDENTIFIER "SERVOKIT_ARCHIVE_${file}" cache_name)
    find_library(${cache_name} NAMES ${file})
    if(NOT ${cache_name})
      message(STATUS "servokit: ${file} not found: the program links shared libraries")
      set(SERVOKIT_STATIC_AVAILABLE OFF PARENT_SCOPE)
    endif()
    list(APPEND paths ${${cache_name}})
  endforeach()
  set(${variable} ${paths} PARENT_SCOPE)
endfunction()

# servokit_third_party(<NAME> <shared target> <static target>): SERVOKIT_<NAME>, the choice.
function(servokit_third_party name shared static)
  set(SERVOKIT_${name} "$<IF:${SERVOKIT_STATIC_CHOSEN},${static},${shared}>" PARENT_SCOPE)
endfunction()

if(SERVOKIT_SANITIZE OR SERVOKIT_FUZZ)
  # The sanitizers' runtime is linked without --as-needed: the shared objects would be loaded too.
  set(SERVOKIT_STATIC_AVAILABLE OFF)
endif()

servokit_archives(ginac_archives libginac.a libcln.a libgmp.a)
servokit_archives(yaml_archives libyaml-cpp.a)
servokit_archives(gsl_archives libgsl.a libgslcblas.a)
servokit_archives(arpack_archives libarpack.a)
servokit_archives(fortran_archives liblapack.a libblas.a)
# The Fortran runtime's archives are the compiler's own.
foreach(runtime gfortran quadmath)
  execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=lib${runtime}.a
                  OUTPUT_VARIABLE path OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(IS_ABSOLUTE "${path}" AND EXISTS "${path}")
    list(APPEND fortran_archives ${path})
  else()
    message(STATUS "servokit: lib${runtime}.a not found: the program links shared libraries")
    set(SERVOKIT_STATIC_AVAILABLE OFF)
  endif()
endforeach()

if(SERVOKIT_STATIC_AVAILABLE)
  # One imported target each, so that the archives stay together and in this order.
  add_library(servokit_static_ginac INTERFACE IMPORTED)
  set_target_properties(servokit_static_ginac PROPERTIES
    INTERFACE_LINK_LIBRARIES "${ginac_archives}"
    INTERFACE_INCLUDE_DIRECTORIES "${GINAC_INCLUDE_DIRS}")
  add_library(servokit_static_yaml_cpp INTERFACE IMPORTED)
  get_target_property(yaml_includes yaml-cpp INTERFACE_INCLUDE_DIRECTORIES)
  set_target_properties(servokit_static_yaml_cpp PROPERTIES
    INTERFACE_LINK_LIBRARIES "${yaml_archives}"
    INTERFACE_INCLUDE_DIRECTORIES "${yaml_includes}")
  add_library(servokit_static_gsl INTERFACE IMPORTED)
  set_target_properties(servokit_static_gsl PROPERTIES
    INTERFACE_LINK_LIBRARIES "${gsl_archives};m"
    INTERFACE_INCLUDE_DIRECTORIES "${GSL_INCLUDE_DIRS}")
  # ARPACK is Fortran: its archive needs LAPACK, BLAS and the Fortran runtime.
  add_library(servokit_static_arpack INTERFACE IMPORTED)
  set_target_properties(servokit_static_arpack PROPERTIES
    INTERFACE_LINK_LIBRARIES "${arpack_archives};${fortran_archives};m")
  servokit_third_party(GINAC PkgConfig::GINAC servokit_static_ginac)
  servokit_third_party(YAML_CPP yaml-cpp servokit_static_yaml_cpp)
  servokit_third_party(GSL GSL::gsl servokit_static_gsl)
  servokit_third_party(ARPACK PkgConfig::ARPACK servokit_static_arpack)
  foreach(package kinsol nvecserial sunmatrixdense sunlinsoldense arkode cvode ida)
    string(TOUPPER ${package} upper)
    servokit_third_party(SUNDIALS_${upper} SUNDIALS::${package}_shared
                         SUNDIALS::${package}_static)
  endforeach()
else()
  set(SERVOKIT_GINAC PkgConfig::GINAC)
  set(SERVOKIT_YAML_CPP yaml-cpp)
  set(SERVOKIT_GSL GSL::gsl)
  set(SERVOKIT_ARPACK PkgConfig::ARPACK)
  foreach(package kinsol nvecserial sunmatrixdense sunlinsoldense arkode cvode ida)
    string(TOUPPER ${package} upper)
    set(SERVOKIT_SUNDIALS_${upper} SUNDIALS::${package}_shared)
  endforeach()
endif()
message(STATUS "servokit: the program links static third-party archives: "
               "${SERVOKIT_STATIC_AVAILABLE}")
