# rocklab.1 from the command's own list (`rocklab help`) and version, so
# the manual page cannot drift from the commands; gzip -9n for the package
# (no timestamp in the .gz: reproducible, as lintian asks).
#   cmake -DROCKLAB=path/to/rocklab -DGZIP=gzip -DOUT=dir/rocklab.1.gz -P manpage.cmake
execute_process(COMMAND ${ROCKLAB} help OUTPUT_VARIABLE list RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "manpage.cmake: ${ROCKLAB} help failed (${rc})")
endif()
execute_process(COMMAND ${ROCKLAB} --version OUTPUT_VARIABLE version OUTPUT_STRIP_TRAILING_WHITESPACE)
string(REGEX MATCHALL "\n  [a-z][-a-z0-9]*  +[^\n]*" lines "${list}")
set(commands "")
foreach(line ${lines})
  string(REGEX REPLACE "^\n  ([-a-z0-9]+)  +(.*)$" "\\1;\\2" pair "${line}")
  list(GET pair 0 name)
  list(GET pair 1 what)
  string(REPLACE "\\" "\\e" what "${what}")
  string(REPLACE "-" "\\-" name_roff "${name}")
  string(APPEND commands ".TP\n.B ${name_roff}\n${what}\n")
endforeach()
get_filename_component(dir ${OUT} DIRECTORY)
get_filename_component(plain ${OUT} NAME_WLE)
file(WRITE ${dir}/${plain} ".TH ROCKLAB 1 \"\" \"${version}\" \"User Commands\"
.SH NAME
rocklab \\- shake-table rocking-block laboratory
.SH SYNOPSIS
.B rocklab
.I COMMAND
[\\fIOPTIONS\\fR]
.br
.B rocklab help
[\\fICOMMAND\\fR]
.SH DESCRIPTION
One program, one command per task: acquisition from the rig, the rocking
models, live comparison, records, sweeps and reports.
.B rocklab help COMMAND
prints a command's options.
.SH COMMANDS
${commands}.SH EXIT STATUS
0 on success, 1 when a command ran and failed, 2 for a bad option, value or input file.
.SH SEE ALSO
/usr/share/doc/rocklab/README.md and the other guides in /usr/share/doc/rocklab.
")
execute_process(COMMAND ${GZIP} -9nf ${dir}/${plain} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "manpage.cmake: gzip failed (${rc})")
endif()
