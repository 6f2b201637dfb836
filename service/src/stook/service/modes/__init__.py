"""The modes: test, batch and report mode, and the settings and inputs they run on."""
