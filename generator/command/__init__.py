"""The `ipgen` command and `ipgen.write_header`: options to a job (`job`), the job's files
derived, rendered (`generate`) and written all-or-nothing (`output`), the command line (`cli`).
"""
