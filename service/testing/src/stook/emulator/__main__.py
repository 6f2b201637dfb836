"""`python -m stook.emulator`: serve the emulator until Ctrl-C."""

from stook.emulator._server import main

if __name__ == "__main__":
    main()
