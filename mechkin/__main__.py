from mechkin.cli.app import main

main()
