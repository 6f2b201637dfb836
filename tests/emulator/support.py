"""Shared helpers for the emulator tests: a raw HTTP client and small configs."""

from __future__ import annotations

from typing import Any

import aiohttp

from stook.emulator import Emulator, EmulatorConfig

# Small pages so that every list needs several requests.
SMALL = EmulatorConfig(
    jobs_per_batch=12,
    report_batches=5,
    report_jobs_per_batch=6,
    default_page_size=5,
    max_page_size=8,
)


class Raw:
    """Plain requests against an emulator, returning (status, parsed JSON or bytes)."""

    def __init__(self, emu: Emulator, session: aiohttp.ClientSession) -> None:
        self.emu = emu
        self.session = session

    @property
    def auth(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.emu.token}"}

    def url(self, path: str) -> str:
        return f"{self.emu.api_url}/projects/{self.emu.project_id}{path}"

    async def get(
        self,
        path: str,
        *,
        params: dict[str, Any] | None = None,
        headers: dict[str, str] | None = None,
    ) -> tuple[int, Any]:
        async with self.session.get(
            self.url(path), params=params, headers=self.auth if headers is None else headers
        ) as answer:
            body = await answer.read()
            if answer.content_type == "application/json":
                return answer.status, await answer.json()
            return answer.status, body

    async def fetch(self, url: str, headers: dict[str, str] | None = None) -> tuple[int, bytes]:
        async with self.session.get(url, headers=headers or {}) as answer:
            return answer.status, await answer.read()

    async def all_pages(
        self, path: str, key: str, *, page_size: int | None = None, **params: Any
    ) -> tuple[list[Any], int]:
        """Every item of a list and the number of requests it took."""
        items: list[Any] = []
        token = ""
        requests = 0
        while True:
            query = dict(params)
            if page_size is not None:
                query["pageSize"] = page_size
            if token:
                query["pageToken"] = token
            status, body = await self.get(path, params=query)
            requests += 1
            assert status == 200, body
            items.extend(body[key])
            token = body.get("nextPageToken") or ""
            if not token:
                return items, requests
