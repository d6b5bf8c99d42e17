# smseg's CMake package and its Debian package.
#
# find_package(smseg CONFIG [REQUIRED] [COMPONENTS module...]): one component per module (the names of
# smseg_add_module: common, forest, sequence, ...), each with its own exported targets file. A consumer
# gets the components it names and the modules they link, public and private (the libraries are static,
# so a consumer's link line needs all of them), and the config looks only for the outside packages of
# those modules: a project that asks for forest never loads OpenCV, PCL or VTK. No COMPONENTS: all.
#
# The outside packages are not listed a second time by hand: smseg_add_module hands its LIBS and
# PRIVATE_LIBS to smseg_package_module, which maps each link item to the package that defines it
# (smseg_outside_package below); smseg_install_package writes the config from what was recorded.

# How the config finds a package again when a module needs it: the arguments after the package's name
# (minimum versions as the top CMakeLists.txt and features/*/CMakeLists.txt ask for them).
set(SMSEG_FIND_ARGS_Eigen3 3.3 NO_MODULE)
set(SMSEG_FIND_ARGS_OpenCV 4)
set(SMSEG_FIND_ARGS_nlohmann_json 3.10)
set(SMSEG_FIND_ARGS_Ceres 2)
set(SMSEG_FIND_ARGS_PCL 1.12)

# The outside package a link item comes from, in `out`: "<Package>" for an imported target
# <Package>::<name> (TBB::tbb, Ceres::ceres), "OpenCV:<component>" for opencv_<component>,
# "PCL:<component>" for pcl_<component> (the targets those configs define), "pkg-config/<prefix>" for
# PkgConfig::<prefix> (made by pkg_check_modules(<prefix> IMPORTED_TARGET <module>)), and "" for a plain
# system library that is linked by name (suitesparseconfig: -lsuitesparseconfig) and needs no search.
function(smseg_outside_package item out)
  if(item MATCHES "^opencv_(.+)$")
    set(package "OpenCV:${CMAKE_MATCH_1}")
  elseif(item MATCHES "^pcl_(.+)$")
    set(package "PCL:${CMAKE_MATCH_1}")
  elseif(item MATCHES "^PkgConfig::(.+)$")
    set(package "pkg-config/${CMAKE_MATCH_1}")
    if(NOT ${CMAKE_MATCH_1}_MODULE_NAME)
      message(FATAL_ERROR "smseg package: ${item} was not made by pkg_check_modules(${CMAKE_MATCH_1} IMPORTED_TARGET <one module>)")
    endif()
  elseif(item MATCHES "^([A-Za-z0-9_]+)::")
    set(package "${CMAKE_MATCH_1}")
  elseif(item MATCHES "^[A-Za-z0-9_.+-]+$" AND NOT TARGET "${item}")
    set(package "")
  else()
    message(FATAL_ERROR "smseg package: no outside package known for the link item '${item}' (teach cmake/package.cmake)")
  endif()
  set(${out} "${package}" PARENT_SCOPE)
endfunction()

# Records module `name` for the package: the smseg modules it links (public and private) and the outside
# packages of its link items. Called by smseg_add_module.
function(smseg_package_module name deps libs)
  set(packages "")
  list(REMOVE_ITEM libs "")
  foreach(item IN LISTS libs)
    smseg_outside_package("${item}" package)
    if(package)
      list(APPEND packages "${package}")
    endif()
  endforeach()
  list(REMOVE_DUPLICATES packages)
  list(REMOVE_ITEM deps "")
  set_property(GLOBAL APPEND PROPERTY SMSEG_PACKAGE_MODULES ${name})
  set_property(GLOBAL PROPERTY SMSEG_PACKAGE_DEPS_${name} "${deps}")
  set_property(GLOBAL PROPERTY SMSEG_PACKAGE_PACKAGES_${name} "${packages}")
endfunction()

# Writes and installs the CMake package (lib/cmake/smseg: the config, its version file, one targets file
# per module) and sets up `cpack -G DEB`. Called once, after every module is defined.
function(smseg_install_package)
  include(CMakePackageConfigHelpers)
  set(dir ${CMAKE_INSTALL_LIBDIR}/cmake/smseg)
  get_property(modules GLOBAL PROPERTY SMSEG_PACKAGE_MODULES)

  # The modules in dependency order (each after every module it links), so that the config can include
  # the targets files in that order and close a request over the dependencies in one backward pass.
  set(ordered "")
  set(remaining ${modules})
  while(remaining)
    set(progress FALSE)
    foreach(m IN LISTS remaining)
      get_property(deps GLOBAL PROPERTY SMSEG_PACKAGE_DEPS_${m})
      set(ready TRUE)
      foreach(d IN LISTS deps)
        if(NOT d IN_LIST ordered)
          set(ready FALSE)
        endif()
      endforeach()
      if(ready)
        list(APPEND ordered ${m})
        list(REMOVE_ITEM remaining ${m})
        set(progress TRUE)
      endif()
    endforeach()
    if(NOT progress)
      message(FATAL_ERROR "smseg package: the modules ${remaining} link each other in a cycle, or a module that does not exist")
    endif()
  endwhile()

  # Per module: its smseg dependencies and its outside packages (with components); per package, the
  # block that finds it, in the order the packages first appear.
  set(tables "")
  set(all_packages "")
  set(with_components "")
  foreach(m IN LISTS ordered)
    get_property(deps GLOBAL PROPERTY SMSEG_PACKAGE_DEPS_${m})
    get_property(packages GLOBAL PROPERTY SMSEG_PACKAGE_PACKAGES_${m})
    set(names "")
    foreach(p IN LISTS packages)
      if(p MATCHES "^(OpenCV|PCL):(.+)$")  # a component of a package
        set(pkg ${CMAKE_MATCH_1})
        list(APPEND components_${m}_${pkg} ${CMAKE_MATCH_2})
        list(APPEND with_components ${pkg})
      else()
        set(pkg ${p})
      endif()
      list(APPEND names ${pkg})
    endforeach()
    list(REMOVE_DUPLICATES names)
    list(APPEND all_packages ${names})
    string(JOIN " " deps_text ${deps})
    string(JOIN " " names_text ${names})
    string(APPEND tables "set(_smseg_deps_${m} ${deps_text})\nset(_smseg_packages_${m} ${names_text})\n")
    foreach(pkg IN LISTS names)
      if(components_${m}_${pkg})
        string(JOIN " " text ${components_${m}_${pkg}})
        string(APPEND tables "set(_smseg_components_${m}_${pkg} ${text})\n")
      endif()
    endforeach()
  endforeach()
  list(REMOVE_DUPLICATES all_packages)

  set(finds "")
  foreach(pkg IN LISTS all_packages)
    if(pkg MATCHES "^pkg-config/(.+)$")
      set(prefix ${CMAKE_MATCH_1})
      string(APPEND finds "if(\"${pkg}\" IN_LIST _smseg_packages)\n"
        "  find_package(PkgConfig QUIET)\n"
        "  if(PKG_CONFIG_FOUND)\n"
        "    pkg_check_modules(${prefix} QUIET IMPORTED_TARGET ${${prefix}_MODULE_NAME})\n"
        "  endif()\n"
        "  if(NOT ${prefix}_FOUND)\n"
        "    _smseg_missing(\"the pkg-config module ${${prefix}_MODULE_NAME}\")\n"
        "  endif()\n"
        "endif()\n")
    elseif(pkg STREQUAL "PCL")
      # Debian's PCL config looks for VTK (an optional dependency of its io, 2d and features parts) and
      # VTK's config then names MPI::MPI_C, which fails in a project without C enabled. smseg uses no VTK:
      # pcl_io links it as a shared library of its own. So the search for VTK is switched off while PCL
      # is found (unless the project found VTK itself, or set the switch).
      string(APPEND finds "if(\"PCL\" IN_LIST _smseg_packages)\n"
        "  set(_smseg_no_vtk FALSE)\n"
        "  if(NOT VTK_FOUND AND NOT DEFINED CMAKE_DISABLE_FIND_PACKAGE_VTK)\n"
        "    set(CMAKE_DISABLE_FIND_PACKAGE_VTK ON)\n"
        "    set(_smseg_no_vtk TRUE)\n"
        "  endif()\n"
        "  find_package(PCL ${SMSEG_FIND_ARGS_PCL} QUIET COMPONENTS \${_smseg_components_PCL})\n"
        "  if(_smseg_no_vtk)\n"
        "    unset(CMAKE_DISABLE_FIND_PACKAGE_VTK)\n"
        "  endif()\n"
        "  if(NOT PCL_FOUND)\n"
        "    _smseg_missing(PCL)\n"
        "  endif()\n"
        "endif()\n")
    else()
      set(args ${pkg} ${SMSEG_FIND_ARGS_${pkg}} "\${_smseg_quiet}")
      if(pkg IN_LIST with_components)
        list(APPEND args COMPONENTS "\${_smseg_components_${pkg}}")
      endif()
      string(JOIN " " args ${args})
      string(APPEND finds "if(\"${pkg}\" IN_LIST _smseg_packages)\n"
        "  find_package(${args})\n"
        "  if(NOT ${pkg}_FOUND)\n"
        "    _smseg_missing(${pkg})\n"
        "  endif()\n"
        "endif()\n")
    endif()
  endforeach()

  foreach(m IN LISTS ordered)
    install(EXPORT smseg_${m}Targets NAMESPACE smseg:: FILE smseg-${m}-targets.cmake DESTINATION ${dir} COMPONENT dev)
  endforeach()
  string(JOIN " " ordered_text ${ordered})
  file(CONFIGURE OUTPUT ${CMAKE_BINARY_DIR}/package/smsegConfig.cmake @ONLY CONTENT [=[
# smseg @PROJECT_VERSION@: find_package(smseg CONFIG REQUIRED [COMPONENTS module...]), then link
# smseg::forest, smseg::stacks, ... The components are the modules: @ordered_text@.
# Written by cmake/package.cmake from what each module links.

# The modules in dependency order; per module, the modules it links (public and private: the libraries
# are static) and the outside packages it needs, with their components.
set(_smseg_modules @ordered_text@)
@tables@
# The components asked for (none: all) and the modules they link, closed over dependencies by one
# backward pass over the dependency order.
set(_smseg_wanted ${smseg_FIND_COMPONENTS})
if(NOT _smseg_wanted)
  set(_smseg_wanted ${_smseg_modules})
endif()
set(_smseg_needed "")
foreach(_smseg_c IN LISTS _smseg_wanted)
  if(_smseg_c IN_LIST _smseg_modules)
    list(APPEND _smseg_needed ${_smseg_c})
  elseif(smseg_FIND_REQUIRED_${_smseg_c})
    set(smseg_FOUND FALSE)
    set(smseg_NOT_FOUND_MESSAGE "no component '${_smseg_c}'; the components are: @ordered_text@")
    return()
  else()
    set(smseg_${_smseg_c}_FOUND FALSE)
  endif()
endforeach()
set(_smseg_reversed ${_smseg_modules})
list(REVERSE _smseg_reversed)
foreach(_smseg_m IN LISTS _smseg_reversed)
  if(_smseg_m IN_LIST _smseg_needed)
    list(APPEND _smseg_needed ${_smseg_deps_${_smseg_m}})
  endif()
endforeach()
list(REMOVE_DUPLICATES _smseg_needed)

# The outside packages of the needed modules only, and the union of their components.
set(_smseg_packages "")
foreach(_smseg_m IN LISTS _smseg_modules)
  foreach(_smseg_p IN LISTS _smseg_packages_${_smseg_m})
    set(_smseg_components_${_smseg_p} "")
  endforeach()
endforeach()
foreach(_smseg_m IN LISTS _smseg_modules)
  if(_smseg_m IN_LIST _smseg_needed)
    foreach(_smseg_p IN LISTS _smseg_packages_${_smseg_m})
      list(APPEND _smseg_packages ${_smseg_p})
      list(APPEND _smseg_components_${_smseg_p} ${_smseg_components_${_smseg_m}_${_smseg_p}})
    endforeach()
  endif()
endforeach()
list(REMOVE_DUPLICATES _smseg_packages)
foreach(_smseg_p IN LISTS _smseg_packages)
  if(_smseg_components_${_smseg_p})
    list(REMOVE_DUPLICATES _smseg_components_${_smseg_p})
  endif()
endforeach()

set(_smseg_quiet "")
if(smseg_FIND_QUIETLY)
  set(_smseg_quiet QUIET)
endif()
# A package that is not found: smseg is not found, with one line naming it (the macro returns from this
# file).
macro(_smseg_missing what)
  set(smseg_FOUND FALSE)
  set(smseg_NOT_FOUND_MESSAGE "${what} was not found; smseg's components ${_smseg_needed} need it")
  return()
endmacro()
@finds@
foreach(_smseg_m IN LISTS _smseg_modules)
  if(_smseg_m IN_LIST _smseg_needed)
    include("${CMAKE_CURRENT_LIST_DIR}/smseg-${_smseg_m}-targets.cmake")
    set(smseg_${_smseg_m}_FOUND TRUE)
  endif()
endforeach()
]=])
  write_basic_package_version_file(${CMAKE_BINARY_DIR}/package/smsegConfigVersion.cmake
    VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
  install(FILES ${CMAKE_BINARY_DIR}/package/smsegConfig.cmake ${CMAKE_BINARY_DIR}/package/smsegConfigVersion.cmake
    DESTINATION ${dir} COMPONENT dev)

  # cpack -G DEB (run in build/): one package with libraries, headers, tools and the Python module,
  # installed under /usr. dpkg-shlibdeps (Debian's dpkg-dev) derives the Depends line from the tools'
  # and the Python module's shared libraries; the Python module also needs the interpreter it was built
  # for and numpy, which no shared library tells.
  set(CPACK_PACKAGE_NAME smseg)
  set(CPACK_PACKAGE_CONTACT "smseg maintainers <smseg@localhost>")
  set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "semantic segmentation from the structure and motion of tracked 3D points")
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
  set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # smseg_0.1.0_amd64.deb
  set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
  if(TARGET _smseg)
    find_package(Python3 COMPONENTS Interpreter)
    set(v ${Python3_VERSION_MAJOR}.${Python3_VERSION_MINOR})
    math(EXPR next "${Python3_VERSION_MINOR} + 1")
    set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3 (>= ${v}), python3 (<< ${Python3_VERSION_MAJOR}.${next}), python3-numpy")
  endif()
  # The headers, static libraries and CMake package are for building against smseg, which also needs
  # the outside packages' headers and configs: suggested, not required (the tools and the Python module
  # run without them). scikit-learn: the estimators are its estimators where it is installed.
  set(CPACK_DEBIAN_PACKAGE_SUGGESTS
      "cmake, pkg-config, libeigen3-dev, libopencv-dev, libopencv-contrib-dev, libpcl-dev, libtbb-dev, nlohmann-json3-dev, libcli11-dev, libceres-dev, libgoogle-glog-dev, libsuitesparse-dev, libmaxflow-dev, python3-sklearn")
  include(CPack)
endfunction()
