"""`python -m stook.service.emulator`: serve the emulator until Ctrl-C."""

from stook.service.emulator._server import main

if __name__ == "__main__":
    main()
