from sgpipe.cli import main

main()
