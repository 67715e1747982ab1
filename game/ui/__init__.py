"""The pygame shell: the app and its screens, rendering, audio, preferences and screenshots."""
