import sys

try:
    from mechkin.cli.app import main
except KeyboardInterrupt:  # Ctrl-C while the command is still starting: nothing began
    sys.stderr.write("mechkin: interrupted (SIGINT); no output was changed\n")
    sys.exit(130)

main()
