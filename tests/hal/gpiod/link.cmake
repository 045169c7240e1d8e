# The GpiodLine tests run the real back-end against a fake GPIO chip: the
# libgpiod calls that reach the kernel are wrapped at link time by the
# interposer of the API this build uses (v1/ for libgpiod 1.6, v2/ for 2.x),
# the same natively and under qemu-user. Chips the fake does not own go to
# the real libgpiod (the missing-chip tests).
target_include_directories(${exe} PRIVATE ${area_dir})
target_compile_definitions(${exe} PRIVATE GYROTC_GPIOD_API=${GYROTC_GPIOD_API})
target_link_libraries(${exe} PRIVATE PkgConfig::GPIOD)
if(GYROTC_GPIOD_API EQUAL 1)
  target_sources(${exe} PRIVATE ${area_dir}/v1/gpiod_v1_interposer.cpp)
  set(_wrapped gpiod_chip_open_lookup gpiod_chip_close gpiod_chip_get_line gpiod_chip_find_line
      gpiod_line_request_output_flags gpiod_line_request_input_flags
      gpiod_line_request_falling_edge_events_flags gpiod_line_request_rising_edge_events_flags
      gpiod_line_set_value gpiod_line_get_value gpiod_line_event_wait gpiod_line_event_read
      gpiod_line_event_read_multiple)
else()
  target_sources(${exe} PRIVATE ${area_dir}/v2/gpiod_v2_interposer.cpp)
  set(_wrapped gpiod_chip_open gpiod_is_gpiochip_device gpiod_chip_close gpiod_chip_get_info
      gpiod_chip_info_get_label gpiod_chip_info_free gpiod_chip_get_line_offset_from_name
      gpiod_chip_request_lines gpiod_line_request_release gpiod_line_request_get_value
      gpiod_line_request_set_value gpiod_line_request_wait_edge_events
      gpiod_line_request_read_edge_events gpiod_edge_event_buffer_new gpiod_edge_event_buffer_free
      gpiod_edge_event_buffer_get_event gpiod_edge_event_get_timestamp_ns opendir readdir readdir64 closedir)
endif()
foreach(_fn ${_wrapped})
  target_link_options(${exe} PRIVATE "-Wl,--wrap=${_fn}")
endforeach()
