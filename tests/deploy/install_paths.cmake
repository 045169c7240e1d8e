# rel_or_abs(<out> <dir>): an install DESTINATION as a path: relative = under PREFIX.
function(rel_or_abs out dir)
  if(IS_ABSOLUTE "${dir}")
    set(${out} "${dir}" PARENT_SCOPE)
  else()
    set(${out} "${PREFIX}/${dir}" PARENT_SCOPE)
  endif()
endfunction()
